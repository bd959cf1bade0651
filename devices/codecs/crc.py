"""The two CRCs the gyro protocols use, table-driven and pure.

* CRC-32/MPEG-2: polynomial 0x04C11DB7, initial 0xFFFFFFFF, not reflected, no final
  XOR; check value 0x0376E6E7 for ``b"123456789"``. Used by the STIM300 (over the
  datagram padded with zero bytes to a multiple of 4) and the KVH DSP-1750.
* CRC-8/SAE-J1850: polynomial 0x1D, initial 0xFF, not reflected, final XOR 0xFF; check
  value 0x4B for ``b"123456789"``. AUTOSAR's ``Crc_CalculateCRC8`` is this CRC; AUTOSAR
  E2E Profile 1 chains it so that its register starts at 0x00 and ends without the final
  XOR (the parameters of CRC-8/GSM-A, check value 0x37): :mod:`devices.codecs.e2e_p01`
  calls it with ``initial=0x00, final_xor=0x00``.
"""

from __future__ import annotations

import binascii


def _table(poly: int, width: int) -> tuple[int, ...]:
    top = 1 << (width - 1)
    mask = (1 << width) - 1
    table = []
    for byte in range(256):
        crc = byte << (width - 8)
        for _ in range(8):
            crc = ((crc << 1) ^ poly) & mask if crc & top else (crc << 1) & mask
        table.append(crc)
    return tuple(table)


_CRC8_TABLE = _table(0x1D, 8)
#: Bit-reversal of every byte value.
_REFLECT = bytes(int(f"{b:08b}"[::-1], 2) for b in range(256))


def crc32_mpeg2(data: bytes | bytearray | memoryview) -> int:
    """CRC-32/MPEG-2 of ``data`` (MSB first, no reflection, no final XOR).

    Computed in C through :func:`binascii.crc32` (the reflected CRC-32 with the same
    polynomial): reflecting every input byte and the 32-bit result turns one into the
    other, and the final XOR of 0xFFFFFFFF is undone.

    Parameters
    ----------
    data : bytes-like
        The bytes to protect.

    Returns
    -------
    int
        The 32-bit CRC.
    """
    reflected = binascii.crc32(bytes(data).translate(_REFLECT)) ^ 0xFFFFFFFF
    return int(f"{reflected:032b}"[::-1], 2)


def crc8_sae_j1850(data: bytes | bytearray | memoryview, *, initial: int = 0xFF,
                   final_xor: int = 0xFF) -> int:
    """CRC-8 with the SAE J1850 polynomial 0x1D (MSB first, no reflection) of ``data``.

    Parameters
    ----------
    data : bytes-like
        The bytes to protect.
    initial, final_xor : int
        Start value of the register and the XOR applied to the result: 0xFF and 0xFF make
        CRC-8/SAE-J1850 (the default); 0x00 and 0x00 the CRC of AUTOSAR E2E Profile 1.

    Returns
    -------
    int
        The 8-bit CRC.
    """
    crc = initial
    table = _CRC8_TABLE
    for byte in bytes(data):
        crc = table[crc ^ byte]
    return crc ^ final_xor
