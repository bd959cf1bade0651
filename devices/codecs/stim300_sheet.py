"""What the STIM300 data sheet says of its normal-mode datagrams, as data.

Source: Safran Sensonor, *STIM300 Datasheet*, TS1524 rev. 31 (February 2024):

* Table 5-11: the sample rates a unit may be configured to (125, 250, 500, 1000,
  2000 samples/s, or an external trigger) and the measurement units of its outputs;
* Table 5-12: the bytes each datagram content transmits (CR/LF excluded) and the
  highest sample rate at each standard bit-rate;
* Table 5-20: the order of the clusters (rate, acceleration, inclination, their
  temperatures, PPS/AUX, counter, latency, CRC); its identifier 0xAF is the datagram with
  the full content on a unit with an AUX input (configuration datagram, Table 5-16,
  byte 14 bit 3);
* Table 5-21: the identifiers of the reduced contents, 0xF0-0xF7 those with PPS;
* Table 5-22: the zero dummy bytes added before the CRC;
* Table 5-23: the status byte (0 = OK; bits 7-3 errors, 2-0 the channel);
* Section 7.5.2.2: the scale factors of each output unit and range (Equations 1-10),
  the counter (7.5.2.2.18: it counts the internal samples at 2000 samples/s, one byte,
  wrapping) and the latency (7.5.2.2.19, microseconds).
"""

from __future__ import annotations

from dataclasses import dataclass

#: The unit's internal sample rate, Hz: what its datagram counter counts (7.5.2.2.18).
INTERNAL_RATE_HZ = 2000
#: The output sample rates a unit can be configured to, Hz (Table 5-11).
OFFERED_RATES_HZ = (125, 250, 500, 1000, 2000)
#: The standard RS422 bit-rates of Table 5-12, bit/s.
STANDARD_BAUDS = (374400, 460800, 921600, 1843200)
COUNTER_MODULUS = 256
#: Table 5-23 bit 6: the unit is still starting up (its data not valid).
STATUS_START_UP = 0x40


@dataclass(frozen=True)
class Content:
    """One datagram content: which clusters follow the rate cluster (Table 5-20 order)."""

    accel: bool
    incl: bool
    temperature: bool
    aux: bool


def _content(name: str) -> Content:
    return Content("A" in name, "I" in name, "T" in name, "P" in name)


#: Identifier -> content (Table 5-21; 0xAF from Table 5-20: the full content, AUX input).
DATAGRAMS: dict[int, Content] = {
    0x90: _content("R"), 0x91: _content("RA"), 0x92: _content("RI"), 0x93: _content("RAI"),
    0x94: _content("RT"), 0xA5: _content("RAT"), 0xA6: _content("RIT"),
    0xA7: _content("RAIT"),
    0xF0: _content("RP"), 0xF1: _content("RAP"), 0xF2: _content("RIP"),
    0xF3: _content("RAIP"), 0xF4: _content("RTP"), 0xF5: _content("RATP"),
    0xF6: _content("RITP"), 0xF7: _content("RAITP"), 0xAF: _content("RAITP"),
}

#: Bytes transmitted per content (Table 5-12, CR/LF excluded), as the sheet prints them.
TABLE_5_12_BYTES: dict[Content, int] = {
    _content("R"): 18, _content("RA"): 28, _content("RI"): 28, _content("RAI"): 38,
    _content("RT"): 25, _content("RAT"): 42, _content("RIT"): 42, _content("RAIT"): 59,
    _content("RP"): 22, _content("RAP"): 32, _content("RIP"): 32, _content("RAIP"): 42,
    _content("RTP"): 29, _content("RATP"): 46, _content("RITP"): 46, _content("RAITP"): 63,
}

#: Highest sample rate (Hz) per content at 374400, 460800, 921600, 1843200 bit/s
#: (Table 5-12).
TABLE_5_12_MAX_RATE_HZ: dict[Content, tuple[int, int, int, int]] = {
    _content("R"): (1000, 2000, 2000, 2000), _content("RA"): (1000, 1000, 2000, 2000),
    _content("RI"): (1000, 1000, 2000, 2000), _content("RAI"): (500, 1000, 2000, 2000),
    _content("RT"): (1000, 1000, 2000, 2000), _content("RAT"): (500, 500, 1000, 2000),
    _content("RIT"): (500, 500, 1000, 2000), _content("RAIT"): (500, 500, 1000, 2000),
    _content("RP"): (1000, 1000, 2000, 2000), _content("RAP"): (1000, 1000, 2000, 2000),
    _content("RIP"): (1000, 1000, 2000, 2000), _content("RAIP"): (500, 500, 1000, 2000),
    _content("RTP"): (1000, 1000, 2000, 2000), _content("RATP"): (500, 500, 1000, 2000),
    _content("RITP"): (500, 500, 1000, 2000), _content("RAITP"): (500, 500, 1000, 2000),
}

#: Zero dummy bytes added to the CRC input per identifier (Table 5-22).
TABLE_5_22_DUMMY_BYTES: dict[int, int] = {
    0x90: 2, 0x91: 0, 0x92: 0, 0x93: 2, 0x94: 3, 0xA5: 2, 0xA6: 2, 0xA7: 1,
    0xF0: 2, 0xF1: 0, 0xF2: 0, 0xF3: 2, 0xF4: 3, 0xF5: 2, 0xF6: 2, 0xF7: 1, 0xAF: 1,
}

# -- scale factors (section 7.5.2.2) --------------------------------------------------

#: Gyro LSB per deg/s: angular rate and average angular rate (Equation 1).
RATE_LSB_PER_DEG_S = 2**14
#: Gyro LSB per deg: incremental angle (per sample) and integrated angle (Equation 2).
ANGLE_LSB_PER_DEG = 2**21
#: Temperature LSB per degC (Equation 9).
TEMP_LSB_PER_DEGC = 2**8
#: Inclinometer LSB per g: acceleration and average acceleration (Equation 5).
INCL_LSB_PER_G = 2**22
#: Accelerometer LSB per g per range variant (g: +-5, +-10, +-30, +-80), acceleration and
#: average acceleration (Equation 3).
ACCEL_LSB_PER_G: dict[int, int] = {5: 2**20, 10: 2**19, 30: 2**18, 80: 2**16}
#: Accelerometer LSB per m/s per range variant, incremental velocity (per sample) and
#: integrated velocity (Equation 4).
ACCEL_LSB_PER_M_S: dict[int, int] = {5: 2**23, 10: 2**22, 30: 2**21, 80: 2**19}

#: The gyro output units of Table 5-11 (URL key ``gyro_output``) this station reads.
GYRO_OUTPUTS = ("rate", "average", "incremental")
#: The accelerometer output units of Table 5-11 (URL key ``accel_output``) it reads.
ACCEL_OUTPUTS = ("acceleration", "average", "incremental")
#: Output units it refuses, with the reason: each sample's value is a running integral
#: that wraps with no flag (Tables 7-1, 7-2, 7-3), so a lost datagram loses how often.
REFUSED_OUTPUTS = {
    "integrated": "an integrated angle or velocity wraps with no flag in the status byte "
                  "(TS1524 Tables 7-1 to 7-3): a lost datagram hides how many times",
}


def payload_length(content: Content) -> int:
    """Bytes before the CRC (Table 5-20 order): identifier, rate cluster (10), the
    acceleration and inclination clusters (10 each), their temperature triples (7 each,
    the rate's too, when temperatures are chosen), PPS/AUX (4), counter (1), latency (2)."""
    clusters = 1 + int(content.accel) + int(content.incl)
    return (1 + 10 * clusters + (7 * clusters if content.temperature else 0)
            + (4 if content.aux else 0) + 3)


def counter_step(rate_hz: float) -> int:
    """Counter units per datagram at an offered output rate (2000 Hz / rate, 7.5.2.2.18).

    Raises
    ------
    ValueError
        A rate the unit does not offer (Table 5-11).
    """
    if rate_hz not in OFFERED_RATES_HZ:
        raise ValueError(rate_hz)
    return INTERNAL_RATE_HZ // int(rate_hz)


def max_rate_hz(identifier: int, baud: int) -> int | None:
    """The highest sample rate (Hz) Table 5-12 allows the datagram at a standard bit-rate
    (None: a user-defined bit-rate, which the table does not list)."""
    if baud not in STANDARD_BAUDS:
        return None
    return TABLE_5_12_MAX_RATE_HZ[DATAGRAMS[identifier]][STANDARD_BAUDS.index(baud)]
