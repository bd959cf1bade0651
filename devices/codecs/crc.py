"""The two CRCs the gyro protocols use, table-driven and pure.

* CRC-32/MPEG-2: polynomial 0x04C11DB7, initial 0xFFFFFFFF, not reflected, no final
  XOR; check value 0x0376E6E7 for ``b"123456789"``. Used by the STIM300 (over the
  datagram padded with zero bytes to a multiple of 4) and the KVH DSP-1750.
* CRC-8/SAE-J1850: polynomial 0x1D, initial 0xFF, not reflected, final XOR 0xFF; check
  value 0x4B for ``b"123456789"``. The AUTOSAR E2E profile 1 CRC used by the raw CAN
  frame layout.
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


def crc8_sae_j1850(data: bytes | bytearray | memoryview) -> int:
    """CRC-8/SAE-J1850 of ``data`` (poly 0x1D, init 0xFF, final XOR 0xFF)."""
    crc = 0xFF
    table = _CRC8_TABLE
    for byte in bytes(data):
        crc = table[crc ^ byte]
    return crc ^ 0xFF
