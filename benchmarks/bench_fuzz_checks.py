"""How often a corrupted frame passes a protocol's check, and what the station then catches.

Xsens Xbus protects a message with an 8-bit sum, a raw CAN frame of the shared layout
with a CRC-8 (SAE J1850). For each, valid frames of a sample stream are corrupted (1, 2
or 3 random bit flips; 2 flips of the same bit in two bytes; the frame's payload
replaced by random bytes) and decoded. Printed per case: frames corrupted, accepted by
the check (the frame decodes), and of those, how many the station's sanity checks then
keep out of the record (a counter out of sequence held and judged by the next frame, a
rate beyond the range, a device time the station's timing rules out), and how many end
up recorded with wrong values (caught by nothing: a mantissa bit of a rate).

Run::

    python benchmarks/bench_fuzz_checks.py              # 100 000 frames per case
    python benchmarks/bench_fuzz_checks.py --frames 20000
"""

from __future__ import annotations

import argparse
import random
import time
from collections.abc import Callable

import numpy as np

from devices.batching import BatchBuilder
from devices.codecs.base import Reading
from devices.codecs.can_frame import SHARED_LAYOUT
from devices.codecs.xbus import XbusCodec
from devices.errors import CodecError
from devices.gaps import CounterTracker

RATE_HZ = 400.0


def _flips(k: int) -> Callable[[bytearray, random.Random], None]:
    def corrupt(buf: bytearray, rng: random.Random) -> None:
        for bit in rng.sample(range(8 * len(buf)), k):
            buf[bit // 8] ^= 1 << (bit % 8)
    return corrupt


def _same_bit_twice(buf: bytearray, rng: random.Random) -> None:
    """The same bit flipped in two bytes (the pair an 8-bit sum misses when one flip
    adds what the other takes away)."""
    i, j = rng.sample(range(len(buf)), 2)
    bit = 1 << rng.randrange(8)
    buf[i] ^= bit
    buf[j] ^= bit


def _random_payload(start: int, end_offset: int) -> Callable[[bytearray, random.Random], None]:
    def corrupt(buf: bytearray, rng: random.Random) -> None:
        for i in range(start, len(buf) - end_offset):
            buf[i] = rng.randrange(256)
    return corrupt


CASES = {"1 bit flipped": _flips(1), "2 bits flipped": _flips(2), "3 bits flipped": _flips(3),
         "same bit in 2 bytes": _same_bit_twice}


def _screen(readings: list[Reading], bad: int, range_deg_s: float, device_time: bool
            ) -> tuple[bool, bool]:
    """Run five consecutive readings (the middle one, ``bad``, corrupted) through the
    station's checks; (kept out of the record, recorded with wrong values)."""
    builder = BatchBuilder(3, CounterTracker(65536 if device_time else 256, RATE_HZ),
                           has_device_time=device_time, has_temperature=False,
                           check_continuity=True, rate_limit_deg_s=range_deg_s)
    for i, r in enumerate(readings):
        t = i / RATE_HZ
        builder.add(r, t, elapsed_s=1.0 / RATE_HZ if i else None,
                    elapsed_range_s=(0.5 / RATE_HZ, 1.5 / RATE_HZ) if i else None)
    batch = builder.take(10.0)
    kept = len(batch) < len(readings)
    wrong = False
    truth = readings[:]
    for rate, counter in zip(batch.rate_deg_s, batch.counter, strict=True):
        matches = [r for r in truth if r.counter == int(counter) % (65536 if device_time else 256)]
        if not matches or not np.allclose(rate, matches[0].rate_deg_s, rtol=0, atol=1e-9):
            wrong = True
    if batch.missing_samples > (1 if kept else 0):
        wrong = True  # a phantom gap
    return kept, wrong


def xbus_case(name: str, corrupt: Callable[[bytearray, random.Random], None], frames: int,
              rng: random.Random) -> tuple[int, int, int, int, int]:
    codec = XbusCodec()
    passed = structure = caught = wrong = 0
    for n in range(frames):
        base = n % 60000
        readings = [Reading(tuple(rng.uniform(-1, 1) for _ in range(3)), base + i, 0,
                            (base + i) / RATE_HZ, 25.0) for i in range(5)]
        originals = [codec.encode(codec.from_reading(r)) for r in readings]
        truth = [codec.to_reading(codec.decode(b).frames[0]) for b in originals]
        buf = bytearray(originals[2])
        corrupt(buf, rng)
        result = codec.decode(bytes(buf))
        if not result.frames or bytes(buf) == originals[2]:
            continue
        passed += 1
        try:
            reading = codec.to_reading(result.frames[0])
        except CodecError:
            structure += 1
            continue
        if reading is None:
            structure += 1
            continue
        seq = [*truth[:2], reading, *truth[3:]]
        kept, bad = _screen(seq, 2, codec.rate_range_deg_s, True)
        caught += kept and not bad
        wrong += bad or (not kept and reading != truth[2])
    return frames, passed, structure, caught, wrong


def can_case(name: str, corrupt: Callable[[bytearray, random.Random], None], frames: int,
             rng: random.Random) -> tuple[int, int, int, int, int]:
    layout = SHARED_LAYOUT
    passed = structure = caught = wrong = 0
    (frame_id,) = layout.arbitration_ids
    for n in range(frames):
        readings = [Reading(tuple(rng.uniform(-3, 3) for _ in range(3)), (n + i) % 256)
                    for i in range(5)]
        truth = []
        encoded = []
        for r in readings:
            (values,) = layout.from_reading(r)
            data = layout.encode(values)
            encoded.append(data)
            truth.append(layout.to_reading({frame_id: layout.decode(frame_id, data)}))
        buf = bytearray(encoded[2])
        corrupt(buf, rng)
        if bytes(buf) == encoded[2]:
            continue
        try:
            values = layout.decode(frame_id, bytes(buf))
        except CodecError:
            continue
        passed += 1
        reading = layout.to_reading({frame_id: values})
        seq = [*truth[:2], reading, *truth[3:]]
        kept, bad = _screen(seq, 2, 4.0, False)
        caught += kept and not bad
        wrong += bad or (not kept and reading != truth[2])
    return frames, passed, structure, caught, wrong


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100_000, help="frames per case")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    print(f"{'protocol, corruption':38s}{'frames':>8s}{'passed the check':>20s}"
          f"{'then caught':>13s}{'recorded wrong':>16s}")
    xbus_cases = {**CASES, "random payload": _random_payload(4, 1)}
    can_cases = {**CASES, "random payload": _random_payload(0, 0)}
    for proto, cases, run in (("Xbus", xbus_cases, xbus_case),
                              ("CAN CRC-8", can_cases, can_case)):
        for name, corrupt in cases.items():
            t0 = time.monotonic()
            frames, passed, structure, caught, wrong = run(name, corrupt, args.frames,
                                                           random.Random(args.seed))
            caught += structure
            print(f"{proto + ', ' + name:38s}{frames:8d}{passed:9d} ({passed / frames:8.2e})"
                  f"{caught:8d} ({caught / max(passed, 1):4.0%}){wrong:8d} "
                  f"({wrong / frames:8.2e})  [{time.monotonic() - t0:.0f} s]")


if __name__ == "__main__":
    main()
