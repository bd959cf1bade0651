"""Velocity random walk of every real ADIS16405 accelerometer axis in ``../shared/real-data``
(run by hand, not in CI; about a minute per unit on two cores).

    python benchmarks/bench_accel_vrw.py

Each ``adis16405_*accel*.csv.gz`` there is read as an accelerometer-only record (in g) and
analysed as ``station analyze`` does, from the start and after the ADIS16405 profile's
300 s warm-up. Per axis it prints the VRW read-off (m/s/sqrt(h)) with its +-1 sigma
interval and taus, whether it is only the white-noise bound, and the read-off a fit
without a white term would give (what units whose fit keeps no N got: the region was then
chosen by the slope alone). The data sheet's typical VRW is 0.2 m/s/sqrt(h) (ADIS16405
rev. B, accelerometer specifications); every axis should read 0.1-0.4, the same with and
without the warm-up cut.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from analysis.figures.readoffs import arw_readoff
from station.evaluation.analyze import analyze_record
from station.storage.csv_records import read_csv_record

REAL_DATA = Path(__file__).resolve().parents[2] / "shared" / "real-data"
WARMUPS_S = (0.0, 300.0)
DATA_SHEET_BAND = (0.1, 0.4)


def main() -> int:
    """Print the table; exit 1 when an axis reads outside :data:`DATA_SHEET_BAND`."""
    files = sorted(REAL_DATA.glob("adis16405_*accel*.csv.gz"))
    if not files:
        print(f"no ADIS16405 accelerometer record in {REAL_DATA}")
        return 2
    print("unit, warm-up [s], axis: VRW [m/s/sqrt(h)] [+-1 sigma] (taus), bound?, "
          "without a fitted white term")
    outside = 0
    for path in files:
        record = read_csv_record(path, sample_rate_hz=100.0, accel_units="g")
        for warmup in WARMUPS_S:
            kept = record.slice_time(warmup) if warmup else record
            for axis in analyze_record(kept):
                f = axis.accel
                assert f is not None and f.vrw_m_s_rt_h is not None
                no_white = dataclasses.replace(axis.fit, values={**axis.fit.values, "N": 0.0})
                other = arw_readoff(axis.allan, no_white, zones=axis.zones)
                low, high = f.vrw_ci_m_s_rt_h or (None, None)
                taus = axis.figures.arw_tau_range_s
                print(f"{path.name.split('_accel')[0]}, {warmup:g}, {axis.name}: "
                      f"{f.vrw_m_s_rt_h:.4f} [{low:.4f}, {high:.4f}] ({taus[0]:g}-{taus[1]:g} s)"
                      f"{', upper bound' if f.vrw_upper_bound else ''}; "
                      f"no white term: {other.value:.4f}")
                outside += not DATA_SHEET_BAND[0] < f.vrw_m_s_rt_h < DATA_SHEET_BAND[1]
    print(f"{outside} axis reading(s) outside {DATA_SHEET_BAND[0]}-{DATA_SHEET_BAND[1]}")
    return 1 if outside else 0


if __name__ == "__main__":
    sys.exit(main())
