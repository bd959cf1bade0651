"""Test helpers: drain a rate source, check its report against a simulator's ledger."""

from __future__ import annotations

import functools
import json
import subprocess
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from devices.errors import DeviceDisconnectedError, DeviceTimeoutError
from devices.protocols import Gap, RateSource, SampleBatch
from devices.sim.faults import SimCore


@dataclass
class Collected:
    """Everything read from a source, concatenated."""

    batches: list[SampleBatch] = field(default_factory=list)
    disconnects: int = 0
    #: Reads that raised DeviceTimeoutError (the adapter's silence limit ran out).
    timeouts: int = 0

    @property
    def counter(self) -> np.ndarray:
        return np.concatenate([b.counter for b in self.batches] or [np.empty(0, np.int64)])

    @property
    def rate(self) -> np.ndarray:
        return np.concatenate([b.rate_deg_s for b in self.batches])

    @property
    def gaps(self) -> list[Gap]:
        return [g for b in self.batches for g in b.gaps]

    @property
    def crc_errors(self) -> int:
        return sum(b.crc_errors for b in self.batches)

    def column(self, name: str) -> np.ndarray:
        return np.concatenate([getattr(b, name) for b in self.batches])

    def event_kinds(self) -> list[str]:
        return [e.kind for b in self.batches for e in b.events]


def collect(source: RateSource, n_samples: int, *, deadline_s: float = 20.0) -> Collected:
    """Read until ``n_samples`` arrived, reopening after disconnects and reading on after
    timeouts, as the recorder does (counted; bounded by time)."""
    out = Collected()
    got = 0
    stop = time.monotonic() + deadline_s
    while got < n_samples:
        if time.monotonic() > stop:
            raise AssertionError(f"only {got} of {n_samples} samples in {deadline_s} s")
        try:
            batch = source.read(0.05)
        except DeviceDisconnectedError:
            out.disconnects += 1
            time.sleep(0.01)
            continue
        except DeviceTimeoutError:
            out.timeouts += 1
            continue
        if len(batch) or batch.events:
            out.batches.append(batch)
            got += len(batch)
    return out


def device_index(collected: Collected, core: SimCore, modulus: int, *, atol: float = 1e-3) -> int:
    """Offset from the adapter's unwrapped counter to the simulator's sample index.

    The first sample the adapter saw may come after whole counter wraps it never saw
    (bytes sent before the port was opened are flushed), so the offset is the multiple
    of the modulus whose generated rate matches the first received one.
    """
    first = int(collected.counter[0])
    start = core.history_start
    history = core.history()
    rate0 = collected.rate[0]
    for k in range(len(history) // modulus + 1):
        idx = first + k * modulus - start
        if 0 <= idx < len(history) and np.allclose(history[idx], rate0, atol=atol, rtol=1e-6):
            return idx + start - first
    raise AssertionError("first received sample matches no generated sample")


def missing_indices(gaps: list[Gap], offset: int) -> set[int]:
    """Simulator indices the adapter declared missing."""
    return {g.after_counter + offset + k + 1 for g in gaps for k in range(g.missing_samples)}


#: The most of a span a loaded host may lose (declared) in a round trip that injects no
#: fault: a starved simulator thread loses what fell due meanwhile, a starved poller
#: misses registers. A CI host lost 119 of 1635 serial samples; none on a quiet host.
LOADED_HOST_LOSS_SHARE = 0.25


def check_books(collected: Collected, offset: int = 0) -> set[int]:
    """Assert the books of what an adapter returned: received + declared missing is
    exactly every sample in the span, none twice, each gap's best count inside its
    ``[missing_low, missing_high]``. Returns the declared missing indices (counter +
    ``offset``). Needs no simulator: a served gyro in another process, a real one."""
    idx = collected.counter + offset
    lo, hi = int(idx[0]), int(idx[-1])
    received = set(idx.tolist())
    assert len(received) == len(idx), "a sample was returned twice"
    for gap in collected.gaps:
        assert gap.low <= gap.missing_samples <= gap.high, gap
    declared = missing_indices(collected.gaps, offset)
    assert not received & declared, "a sample declared missing was received"
    assert received | declared == set(range(lo, hi + 1)), "a jump of the counter not declared"
    return declared


def check_lost_share(collected: Collected, declared: set[int],
                     share: float = LOADED_HOST_LOSS_SHARE) -> None:
    """Assert that at most ``share`` of the span was declared missing."""
    span = len(collected.counter) + len(declared)
    assert len(declared) <= share * span, f"{len(declared)} of {span} samples lost"


def check_accounting(collected: Collected, core: SimCore, offset: int) -> tuple[set[int], set[int]]:
    """Assert the books (:func:`check_books`) and that the simulator's ledger agrees.

    Returns ``(declared missing, lost per the simulator's ledger)`` inside the span; the
    ledger's losses are always among the declared ones.
    """
    declared = check_books(collected, offset)
    idx = collected.counter + offset
    lo, hi = int(idx[0]), int(idx[-1])
    lost = {i for i in core.ledger.lost_indices.copy() if lo <= i <= hi}
    assert lost <= declared
    return declared, lost


@functools.cache
def multicast_unavailable() -> str:
    """Why python-can's ``udp_multicast`` bus cannot work on this host ("" if it can): a
    frame sent on a fresh group and port must come back (a host with no IPv4 multicast
    route, e.g. a container without a network, has no such bus)."""
    from devices.sim.process import MulticastChannel

    channel = MulticastChannel.fresh()
    a, b = channel.transport(), channel.transport()
    try:
        a.open()
        b.open()
        a.send(0x123, b"probe")
        msg = b.recv(2.0)
    except DeviceDisconnectedError as exc:
        return f"no udp_multicast bus on this host: {exc}"
    finally:
        a.close()
        b.close()
    return "" if msg is not None and bytes(msg.data) == b"probe" else (
        "no udp_multicast bus on this host: a frame sent on it never came back")


def serve(url: str, seconds: float) -> tuple[subprocess.Popen[str], dict[str, object]]:
    """``station devices serve URL --json`` in a process of its own, as a user runs it:
    the process and its first line ({"url", "sim_url", "pid"}); the caller ends it."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "station.cli", "devices", "serve", url, "--json",
         "--seconds", str(seconds)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line:
        proc.kill()
        raise AssertionError(f"serve printed nothing: {proc.stderr.read() if proc.stderr else ''}")
    return proc, json.loads(line)


@dataclass(frozen=True)
class GapTruth:
    """A gap as declared next to what the simulator really lost there."""

    declared: Gap | None
    lost: int

    @property
    def held(self) -> bool:
        """Whether the declared interval holds the samples really lost (no gap: none)."""
        if self.declared is None:
            return self.lost == 0
        return self.declared.low <= self.lost <= self.declared.high

    @property
    def width(self) -> int:
        """Samples between the fewest and the most declared (0: certain)."""
        return 0 if self.declared is None else self.declared.high - self.declared.low


def gap_truths(collected: Collected, core: SimCore, modulus: int, *, atol: float = 1e-4,
               max_wraps: int = 2000) -> list[GapTruth]:
    """Each gap the adapter declared (and each jump it did not) against what the simulator
    lost, found without trusting the adapter's unwrapping: every received sample is the
    first later generated sample whose counter residue (``modulus``: samples per wrap)
    and rate match it."""
    counter, rate = collected.counter, collected.rate
    history, start = core.history(), core.history_start
    true = int(counter[0]) + device_index(collected, core, modulus, atol=atol)
    by_after = {g.after_counter: g for g in collected.gaps}
    out = []
    for j in range(1, len(counter)):
        step = (int(counter[j]) - int(counter[j - 1])) % modulus or modulus
        for k in range(max_wraps):
            idx = true + step + k * modulus
            if idx - start >= len(history):
                raise AssertionError(f"sample {j} matches no generated sample")
            if np.allclose(history[idx - start], rate[j], atol=atol, rtol=1e-6):
                break
        gap = by_after.get(int(counter[j - 1]))
        if gap is not None or idx - true > 1:
            out.append(GapTruth(gap, idx - true - 1))
        true = idx
    return out


def replay_batches(url: str) -> tuple[list[SampleBatch], RateSource]:
    """Every batch a ``replay://`` URL's adapter gives until the end of its file, and the
    adapter (closed; :meth:`describe` still answers)."""
    from devices.replay import EndOfReplayError
    from devices.urls import open_device

    source = open_device(url).source
    source.open()
    batches = []
    try:
        while True:
            batches.append(source.read(0.05))
    except EndOfReplayError:
        pass
    finally:
        source.close()
    return batches, source
