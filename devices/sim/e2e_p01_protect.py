"""AUTOSAR E2E Profile 1 protection as a simulated CAN node applies it, written from the
standard's steps rather than from the codec, so that a misreading cannot pass both sides.

``E2E_P01Protect`` as zariiii9003/autosar-e2e (``src/e2e/p01.c``) and COVESA/vsomeip
(``profile_01.cpp``, which quotes the standard's pseudo code line by line) carry it out:

1. the alive counter goes into its nibble: +1 per frame sent, 14 wraps to 0;
2. ``CRC = Crc_CalculateCRC8(DataID low byte, 1, 0xFF, FALSE)``, then the high byte (mode
   BOTH), the low byte alone (LOW), the low or high byte by the counter's parity (ALT),
   or the low byte and a zero byte (NIBBLE, whose nibble is written into the frame);
3. ``CRC = Crc_CalculateCRC8(data before the CRC byte, ..., CRC, FALSE)``, then over the
   bytes after it;
4. the CRC byte is ``CRC ^ 0xFF``.

``Crc_CalculateCRC8`` is the AUTOSAR CRC library's CRC-8 (SAE J1850: polynomial 0x1D,
start value 0xFF, final XOR 0xFF); called with ``Crc_IsFirstCall = FALSE`` its register
starts at the start value XOR 0xFF. Here it is computed bit by bit, not from a table.
"""

from __future__ import annotations

#: CRC-8 SAE J1850 polynomial (x^8 + x^4 + x^3 + x^2 + 1).
SAE_J1850_POLYNOMIAL = 0x1D
#: ``CRC8_XOR_VALUE`` of the AUTOSAR CRC library.
CRC8_XOR_VALUE = 0xFF
#: Profile 1's alive counter runs 0..14.
ALIVE_COUNTER_WRAP = 15


def crc_calculate_crc8(data: bytes, start_value: int) -> int:
    """``Crc_CalculateCRC8(data, len(data), start_value, FALSE)``, bit by bit.

    Parameters
    ----------
    data : bytes
        The bytes.
    start_value : int
        The previous call's result (0xFF for the first).

    Returns
    -------
    int
        The CRC as the library returns it (XORed by 0xFF).
    """
    crc = start_value ^ CRC8_XOR_VALUE
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = ((crc << 1) ^ SAE_J1850_POLYNOMIAL) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc ^ CRC8_XOR_VALUE


class Profile1Protector:
    """Writes the alive counter and the CRC into a frame, as ``E2E_P01Protect`` does.

    Parameters
    ----------
    data_id : int
        The frame's 16-bit DataID.
    data_id_mode : {"both", "low", "alt", "nibble"}
        How the DataID goes into the CRC.
    crc_byte : int
        Index of the CRC byte.
    counter_byte : int
        Index of the counter's byte.
    counter_shift : int or None
        0 (low nibble) or 4 (high nibble): the frame carries Profile 1's alive counter,
        written here; None: another counter, already in the frame (an 8-bit one), whose
        value is passed to :meth:`protect`.
    """

    def __init__(self, data_id: int, data_id_mode: str, crc_byte: int, counter_byte: int,
                 counter_shift: int | None) -> None:
        self.data_id = data_id
        self.data_id_mode = data_id_mode
        self.crc_byte = crc_byte
        self.counter_byte = counter_byte
        self.counter_shift = counter_shift

    def protect(self, data: bytearray, sample_index: int, counter: int) -> None:
        """Protect the frame of sample ``sample_index`` in place. Profile 1's alive counter
        is the index modulo 15, written here; another counter is ``counter``, already in
        the frame (the parity of either picks the DataID byte in ``alt`` mode)."""
        if self.counter_shift is not None:
            counter = sample_index % ALIVE_COUNTER_WRAP
            keep = 0xF0 if self.counter_shift == 0 else 0x0F
            data[self.counter_byte] = (data[self.counter_byte] & keep) | (
                counter << self.counter_shift)
        low, high = self.data_id & 0xFF, self.data_id >> 8
        mode = self.data_id_mode
        if mode == "alt":
            crc = crc_calculate_crc8(bytes((low if counter % 2 == 0 else high,)), 0xFF)
        else:
            crc = crc_calculate_crc8(bytes((low,)), 0xFF)
        if mode == "both":
            crc = crc_calculate_crc8(bytes((high,)), crc)
        elif mode == "nibble":
            nibble_shift = 4 - (self.counter_shift or 0)
            data[self.counter_byte] = (data[self.counter_byte] & ~(0x0F << nibble_shift)
                                       & 0xFF) | ((high & 0x0F) << nibble_shift)
            crc = crc_calculate_crc8(b"\x00", crc)
        if self.crc_byte > 0:
            crc = crc_calculate_crc8(bytes(data[:self.crc_byte]), crc)
        if self.crc_byte < len(data) - 1:
            crc = crc_calculate_crc8(bytes(data[self.crc_byte + 1:]), crc)
        data[self.crc_byte] = crc ^ CRC8_XOR_VALUE
