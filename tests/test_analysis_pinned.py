"""``station analyze`` gives the numbers it gave before the speed work of issue 40, within
1e-12 relative: every number of its JSON for a deterministic simulated record (white and
random-walk rate noise, a 7.3 Hz tone, three spikes; 20 min at 100 Hz) against
``tests/data/analyze_reference.json``, written by the code of commit 2e62cd7 (before the
lazy imports, the numpy Welch spectrum and the compiled lag-1 sums) on the same record.

209 numbers were re-pinned with the closed-form edf of the overlapping Allan variance
(:mod:`analysis.allan.edf_closed_form`), all of them the edf and what follows from it: the
edf of the 36 white-rate taus with m > 1365, where the numeric lag sum sampled its lags
(off by up to 5.4e-5 there; the closed form equals a sum over every lag within 1e-13,
``tests/test_edf_closed_form.py``), their intervals (up to 7.2e-5) and the fit weighted by
them (up to 2e-6). Every other number is still 2e62cd7's within 1e-12."""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path

import numpy as np

from station.cli import main
from station.storage.csv_records import write_csv_record

REFERENCE = Path(__file__).parent / "data" / "analyze_reference.json"


def pinned_record(path: Path) -> None:
    """The record the reference was computed on (seeded: the same samples every run)."""
    rng = np.random.default_rng(20260406)
    n, fs = 120_000, 100.0
    t = np.arange(n) / fs
    white = 0.02 * rng.standard_normal(n)
    walk = np.cumsum(rng.standard_normal(n)) * 2e-5
    tone = 0.01 * np.sin(2 * np.pi * 7.3 * t)
    rate = 0.5 + white + walk + tone
    rate[[5000, 60000, 90000]] += 0.5  # three spikes
    write_csv_record(path, rate[:, None], fs, axis_names=("x",))


def numbers(doc: object, where: str = "") -> dict[str, object]:
    """Every number (and string, for the same keys and verdicts) of a JSON document, by path."""
    out: dict[str, object] = {}
    if isinstance(doc, dict):
        for key, value in doc.items():
            out.update(numbers(value, f"{where}/{key}"))
    elif isinstance(doc, list):
        for i, value in enumerate(doc):
            out.update(numbers(value, f"{where}[{i}]"))
    else:
        out[where] = doc
    return out


def test_analyze_numbers_are_todays_within_1e12(tmp_path: Path) -> None:
    path = tmp_path / "pinned.csv"
    pinned_record(path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["analyze", str(path), "--json"]) == 0
    ours = json.loads(out.getvalue())
    ours.pop("file")
    expected = numbers(json.loads(REFERENCE.read_text()))
    got = numbers(ours)
    # every number of then is there (keys added since, as figures' bound flags, may join)
    assert set(expected) <= set(got)
    assert any(k.startswith("/axes[0]/tones[0]") for k in got)  # the tone is found
    off = {}
    for key, value in expected.items():
        mine = got[key]
        if isinstance(value, float) and isinstance(mine, float) and math.isfinite(value):
            if abs(mine - value) > 1e-12 * abs(value):
                off[key] = (value, mine)
        elif mine != value:
            off[key] = (value, mine)
    assert off == {}
