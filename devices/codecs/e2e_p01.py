"""AUTOSAR E2E Profile 1: the CRC and the alive counter a raw CAN layout may carry (pure).

As the Profile 1 routines read in zariiii9003/autosar-e2e (``src/e2e/p01.c``:
``compute_p01_crc``, ``e2e_p01_check``) and COVESA/vsomeip
(``implementation/e2e_protection/.../profile01/profile_01.cpp``: ``compute_crc``):

* The CRC is AUTOSAR's ``Crc_CalculateCRC8`` (CRC-8/SAE-J1850, polynomial 0x1D) chained
  over the DataID bytes the DataID mode names, then the data bytes before the CRC byte,
  then those after it; each call continues from the previous result with the start value
  XORed by 0xFF (the first from 0xFF), and its result is XORed by 0xFF; Profile 1 XORs the
  last result by 0xFF once more. The XORs cancel: the register starts at 0x00 and the CRC
  has no final XOR.
* DataID modes: ``both`` (low byte, then high byte: E2E variant 1A), ``low`` (the low byte
  only), ``alt`` (the low byte where the counter is even, the high byte where it is odd:
  variant 1B), ``nibble`` (the low byte, then a zero byte; the low nibble of the high byte
  is sent in the frame and checked: variant 1C).
* The alive counter is 4 bits, 0..14: +1 per frame sent, 14 wraps to 0. A receiver's
  check fails on 15 (``e2e_p01_check``: "counter must be in 0-14").

Reference frames: ``../shared/real-captures/can-e2e/profile1-vectors.txt``.
"""

from __future__ import annotations

from typing import Literal, get_args

from devices.codecs.crc import crc8_sae_j1850

#: The alive counter's wrap: 0..14 (15 is not a valid value).
ALIVE_COUNTER_MODULUS = 15
#: Width of the alive counter, bits.
ALIVE_COUNTER_BITS = 4

DataIdMode = Literal["both", "low", "alt", "nibble"]
#: The DataID inclusion modes, as a layout's ``data_id_mode`` names them.
DATA_ID_MODES: tuple[str, ...] = get_args(DataIdMode)


def data_id_bytes(data_id: int, mode: DataIdMode, counter: int) -> bytes:
    """The bytes of the 16-bit ``data_id`` that go into the CRC before the data, in order.

    Parameters
    ----------
    data_id : int
        The DataID, 0..0xFFFF.
    mode : {"both", "low", "alt", "nibble"}
        The DataID inclusion mode.
    counter : int
        The frame's alive counter (its parity picks the byte in ``alt`` mode).

    Returns
    -------
    bytes
    """
    low, high = data_id & 0xFF, (data_id >> 8) & 0xFF
    if mode == "both":
        return bytes((low, high))
    if mode == "low":
        return bytes((low,))
    if mode == "alt":
        return bytes((low if counter % 2 == 0 else high,))
    return bytes((low, 0x00))  # nibble: the high byte's nibble travels in the frame


def p01_crc(data: bytes | bytearray, crc_byte: int, data_id: int, mode: DataIdMode,
            counter: int) -> int:
    """The Profile 1 CRC of a frame's data bytes.

    Parameters
    ----------
    data : bytes-like
        The frame's data bytes (the CRC byte's own value is ignored).
    crc_byte : int
        Index of the CRC byte (Profile 1's CRCOffset / 8).
    data_id, mode, counter
        As :func:`data_id_bytes`.

    Returns
    -------
    int
        The 8-bit CRC.
    """
    body = bytes(data[:crc_byte]) + bytes(data[crc_byte + 1:])
    return crc8_sae_j1850(data_id_bytes(data_id, mode, counter) + body, initial=0x00,
                          final_xor=0x00)
