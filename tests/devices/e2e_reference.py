"""AUTOSAR E2E Profile 1's CRC from its definition, for the tests to check the codec and
the simulated node against (neither's code): CRC-8 with the SAE J1850 polynomial 0x1D,
MSB first, computed bit by bit, register started at 0x00 and no final XOR (AUTOSAR's
Crc_CalculateCRC8 chained by E2E_P01Protect with its XORs cancelling: zariiii9003/
autosar-e2e ``src/e2e/p01.c``, COVESA/vsomeip ``profile_01.cpp``), over the DataID bytes
of the frame's mode and the data bytes but the CRC's own."""

from __future__ import annotations


def p01_reference_crc(message: bytes) -> int:
    """CRC of ``message`` (the DataID bytes, then the data bytes without the CRC byte)."""
    register = 0x00
    for byte in message:
        for bit in range(7, -1, -1):
            feedback = ((register >> 7) ^ (byte >> bit)) & 1
            register = ((register << 1) & 0xFF) ^ (0x1D if feedback else 0)
    return register
