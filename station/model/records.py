"""A rate record in memory: samples per axis in deg/s on a time grid that may have gaps."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from analysis.allan import blocks
from station.errors import RecordFormatError


@dataclass(frozen=True)
class RateRecord:
    """A static gyro record in memory.

    Attributes
    ----------
    rate_deg_s : ndarray, shape (N, k)
        Rate per axis in deg/s.
    sample_rate_hz : float
        Sample rate in Hz.
    axis_names : tuple of str
        One name per column of ``rate_deg_s``.
    source : str
        Where the record came from (a path), for reports.
    temperature_c : ndarray or None
        Temperature in degC per sample, when the record has one.
    sample_index : ndarray of int or None
        Where each sample sits on the record's time grid (sample ``i`` was taken
        ``sample_index[i] / sample_rate_hz`` s after the first, so ``sample_index[0]``
        is 0): samples missing in gaps are skipped indices. None for a record without
        gaps (the indices are then ``0 .. N - 1``).
    accel_m_s2 : ndarray, shape (N, j), or None
        Specific force per accelerometer axis in m/s^2, one row per row of
        ``rate_deg_s`` (the same samples, times and gaps); None for a gyro-only record.
    accel_axis_names : tuple of str
        One name per column of ``accel_m_s2`` (empty without accelerometers).
    """

    rate_deg_s: NDArray[np.float64]
    sample_rate_hz: float
    axis_names: tuple[str, ...]
    source: str = ""
    temperature_c: NDArray[np.float64] | None = field(default=None)
    sample_index: NDArray[np.int64] | None = field(default=None)
    accel_m_s2: NDArray[np.float64] | None = field(default=None)
    accel_axis_names: tuple[str, ...] = ()

    @property
    def n_samples(self) -> int:
        """Number of samples per axis (those present; missing ones are not counted)."""
        return int(self.rate_deg_s.shape[0])

    @property
    def span_samples(self) -> int:
        """Length of the record on its time grid, missing samples included."""
        return self.n_samples if self.sample_index is None else int(self.sample_index[-1]) + 1

    @property
    def duration_s(self) -> float:
        """Length of the record in seconds of true time (gaps included)."""
        return self.span_samples / self.sample_rate_hz

    @property
    def missing_samples(self) -> int:
        """Samples missing in gaps inside the record."""
        return self.span_samples - self.n_samples

    def present_mask(self) -> NDArray[np.bool_]:
        """True at each grid index that holds a sample (length :attr:`span_samples`)."""
        mask = np.zeros(self.span_samples, dtype=bool)
        mask[slice(None) if self.sample_index is None else self.sample_index] = True
        return mask

    def gridded(self, column: int, out: NDArray[np.float64] | None = None
                ) -> NDArray[np.float64]:
        """One axis' rate (deg/s) on the time grid, NaN where a sample is missing; written
        into ``out`` (shape (:attr:`span_samples`,), e.g. a memmap for a long record: a
        block at a time) when given."""
        if self.sample_index is None:
            return self.rate_deg_s[:, column]
        if out is None:
            out = np.full(self.span_samples, np.nan)
            out[self.sample_index] = self.rate_deg_s[:, column]
            return out
        if out.shape != (self.span_samples,):
            raise ValueError(f"out must have shape {(self.span_samples,)}, got {out.shape}")
        done = 0  # grid indices below this are written
        for a, b in blocks.spans(0, self.n_samples):
            index = np.asarray(self.sample_index[a:b])
            out[done : int(index[-1]) + 1] = np.nan
            out[index] = self.rate_deg_s[a:b, column]
            done = int(index[-1]) + 1
            for arr in (out, self.sample_index, self.rate_deg_s):
                blocks.release(arr)
        return out

    def on_time_grid(self) -> NDArray[np.float64]:
        """Every axis' rate (deg/s) on the sample grid, NaN where a sample is missing
        (shape (:attr:`span_samples`, axes)); the rates themselves when nothing is."""
        if self.sample_index is None:
            return self.rate_deg_s
        out = np.full((self.span_samples, self.rate_deg_s.shape[1]), np.nan)
        out[self.sample_index] = self.rate_deg_s
        return out

    def select(self, axis: str | int) -> RateRecord:
        """A record with only one axis, chosen by name or index."""
        if isinstance(axis, str):
            # a rate axis first: an IMU's accelerometer axes often share the gyros' names
            if axis not in self.axis_names and axis in self.accel_axis_names:
                return self.select_accel(axis)
            if axis not in self.axis_names:
                raise RecordFormatError(
                    f"no axis {axis!r} in {self.source or 'the record'}; axes: "
                    f"{', '.join(self.axis_names)}"
                )
            index = self.axis_names.index(axis)
        else:
            index = axis
        return RateRecord(self.rate_deg_s[:, index : index + 1], self.sample_rate_hz,
                          (self.axis_names[index],), self.source, self.temperature_c,
                          self.sample_index, self.accel_m_s2, self.accel_axis_names)

    def select_accel(self, name: str) -> RateRecord:
        """A record with only the accelerometer axis ``name`` (no rate axis left)."""
        if self.accel_m_s2 is None or name not in self.accel_axis_names:
            raise RecordFormatError(f"no accelerometer axis {name!r} in "
                                    f"{self.source or 'the record'}")
        j = self.accel_axis_names.index(name)
        return RateRecord(self.rate_deg_s[:, :0], self.sample_rate_hz, (), self.source,
                          self.temperature_c, self.sample_index,
                          self.accel_m_s2[:, j : j + 1], (name,))

    def slice_time(self, start_s: float = 0.0, stop_s: float | None = None, *,
                   index_out: Callable[[int], NDArray[np.int64]] | None = None) -> RateRecord:
        """The part of the record between ``start_s`` and ``stop_s`` (seconds of true time
        from its start, gaps included); the slice starts at its first sample present.
        ``index_out(n)`` gives the array (e.g. a memmap) a long record's sliced sample
        index is written to, a block at a time."""
        i0 = max(0, int(round(start_s * self.sample_rate_hz)))
        i1 = self.span_samples if stop_s is None else int(round(stop_s * self.sample_rate_hz))
        if self.sample_index is None:
            k0, k1 = min(i0, self.n_samples), min(max(i1, i0), self.n_samples)
        else:
            k0, k1 = (int(k) for k in np.searchsorted(self.sample_index, [i0, max(i1, i0)]))
        if k1 - k0 < 2:
            raise RecordFormatError(
                f"time slice {start_s}..{stop_s} s leaves fewer than 2 samples of a "
                f"{self.duration_s:.1f} s record"
            )
        temp = None if self.temperature_c is None else self.temperature_c[k0:k1]
        index = (None if self.sample_index is None
                 else regular_or_none(self.sample_index[k0:k1], index_out))
        accel = None if self.accel_m_s2 is None else self.accel_m_s2[k0:k1]
        return RateRecord(self.rate_deg_s[k0:k1], self.sample_rate_hz, self.axis_names,
                          self.source, temp, index, accel, self.accel_axis_names)


def regular_or_none(sample_index: NDArray[np.int64],
                    out: Callable[[int], NDArray[np.int64]] | None = None
                    ) -> NDArray[np.int64] | None:
    """Grid indices made to start at 0, or None when they have no gap (a contiguous record).
    A long index (:func:`analysis.allan.blocks.is_long`) is read a block at a time and, shifted,
    written to ``out(len)`` when ``out`` is given.

    Raises
    ------
    RecordFormatError
        Indices that do not increase (two samples at one time, or out of order).
    """
    if out is not None and blocks.is_long(len(sample_index)):
        return _regular_or_none_long(sample_index, out)
    index = np.asarray(sample_index, dtype=np.int64)
    if len(index) and np.any(np.diff(index) < 1):
        row = int(np.argmax(np.diff(index) < 1)) + 1
        raise RecordFormatError(
            f"sample {row} is not later than the one before it on the time grid"
        )
    index = index - index[0] if len(index) else index
    return None if not len(index) or index[-1] == len(index) - 1 else index


def _regular_or_none_long(sample_index: NDArray[np.int64],
                          out: Callable[[int], NDArray[np.int64]]) -> NDArray[np.int64] | None:
    n = len(sample_index)
    first, last = int(sample_index[0]), int(sample_index[-1])
    previous = first - 1
    for a, b in blocks.spans(0, n):
        step = np.diff(np.concatenate(([previous], np.asarray(sample_index[a:b]))))
        if np.any(step < 1):
            raise RecordFormatError(f"sample {a + int(np.argmax(step < 1))} is not later than "
                                    f"the one before it on the time grid")
        previous = int(sample_index[b - 1])
        blocks.release(sample_index)
    if last - first == n - 1:
        return None
    shifted = out(n)
    for a, b in blocks.spans(0, n):
        np.subtract(sample_index[a:b], first, out=shifted[a:b])
        blocks.release(sample_index)
        blocks.release(shifted)
    return shifted
