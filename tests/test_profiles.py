"""Product profiles: the shipped ones, name resolution, and errors that point at file, line and
key."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from analysis.models.noise import flicker_rate_noise, white_angle_noise, white_rate_noise
from analysis.units.conversions import arw_deg_rt_h_to_deg_rt_s, q_urad_to_deg, rate_deg_h_to_deg_s
from station.errors import ProfileError, StationError
from station.evaluation.grading import grade_run
from station.model.profiles import (
    PROFILE_DIR,
    available_profiles,
    load_profile,
    parse_profile,
)
from station.model.records import RateRecord
from station.model.runs import RunInfo, UnitRun
from station.model.toml_lines import key_lines
from tests.test_grading import profile_text

SHIPPED = ("SRS2000", "VG951", "CRG20", "ADIS16405")
#: Lv et al. 2015 tables 1, 3, 5: (table, N deg/sqrt(h), B deg/h).
LV2015 = {"SRS2000": ("table 1", 8.587e-5, 6.773e-3), "VG951": ("table 3", 7.636e-3, 1.246e-1),
          "CRG20": ("table 5", 1.492, 2.079e1)}


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_profiles_load(name: str) -> None:
    p = load_profile(name)
    assert p.name == name and p.model == name and p.version == "1"
    assert p.sample_rate_hz and p.sample_rate_hz > 0
    assert p.duration_s > p.warmup_s > 0 and p.axes
    assert p.transport["url"].startswith(("serial://", "sim+serial://"))
    assert p.rule in ("strict", "guard-banded", "simple")
    assert any(f.graded for f in p.figures)
    assert len(p.sha256) == 64 and Path(p.path) == PROFILE_DIR / f"{name}.toml"
    assert load_profile(PROFILE_DIR / f"{name}.toml") == p  # by path, the same profile
    assert load_profile(f"{name}.toml") == p


@pytest.mark.parametrize("name", sorted(LV2015))
def test_lv2015_profiles_follow_their_table(name: str) -> None:
    """The best grade admits a gyro with the table's fitted figures, within a factor 2, and says
    which
    table."""
    table, arw, bi = LV2015[name]
    p = load_profile(name)
    text = Path(p.path).read_text(encoding="utf-8")
    assert re.search(rf"^#.*{table}", text, re.MULTILINE | re.IGNORECASE), (
        "source table named in a comment"
    )
    best = p.grades[0]
    assert arw < p.figure("arw_fit").limits[best] < 2 * arw
    assert bi < p.figure("bias_instability_fit").limits[best] < 2 * bi
    assert not p.figure("arw").graded and not p.figure("bias_instability").graded


@pytest.mark.parametrize(("arw_factor", "grade"), [(1.0, "A"), (4.0, "reject")])
def test_simulated_crg20_grades_by_its_noise(arw_factor: float, grade: str) -> None:
    """A simulated CRG20 with table 5's Q, N, B over the profile's 1 h test makes grade A; one with
    four times the angle random walk is rejected (fitted N above grade B's 4.5 deg/sqrt(h))."""
    p = load_profile("CRG20")
    fs, n = p.sample_rate_hz, int(p.duration_s * p.sample_rate_hz)
    rng = np.random.default_rng(1)
    rate = (white_rate_noise(arw_deg_rt_h_to_deg_rt_s(1.492 * arw_factor), n, fs, rng)
            + flicker_rate_noise(rate_deg_h_to_deg_s(20.79), n, fs, rng)
            + white_angle_noise(q_urad_to_deg(18.68), n, fs, rng))
    unit = UnitRun("u1", "CRG20", "SN-1", RateRecord(rate.reshape(-1, 1), fs, ("x",)))
    graded = grade_run(RunInfo(path="simulated", units=(unit,)), p).units[0]
    assert graded.grade == grade
    n_fit = next(f for f in graded.axes[0].figures if f.name == "arw_fit")
    assert n_fit.ci_low < 1.492 * arw_factor < n_fit.ci_high * 1.05


def test_mems_profile_matches_the_data_sheet() -> None:
    p = load_profile("ADIS16405")
    assert p.axes == ("x", "y", "z")
    assert p.figure("arw").limits["datasheet"] == 2.0 and p.figure("arw").unit == "deg/sqrt(h)"
    assert (
        p.figure("adev_min").limits["datasheet"] == 0.007 and p.figure("adev_min").unit == "deg/s"
    )


def test_profile_is_frozen_and_lists_available() -> None:
    p = load_profile("SRS2000")
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.name = "other"  # type: ignore[misc]
    assert set(SHIPPED) <= set(available_profiles())


def test_unknown_name_lists_available() -> None:
    with pytest.raises(ProfileError, match="available: .*SRS2000"):
        load_profile("NOPE")


def test_key_lines_follow_tables_and_dotted_keys() -> None:
    lines = key_lines(
        'a = 1\n[t]\nb = 2\n\n[figures.arw]\nunit = "x"\nlimits = { A = 1 }\nc.d = 3\n'
    )
    assert lines[("a",)] == 1 and lines[("t", "b")] == 3
    assert lines[("figures", "arw")] == 5 and lines[("figures", "arw", "limits")] == 7
    assert lines[("figures", "arw", "c", "d")] == 8


BASE = profile_text()


def _line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), start=1) if needle in line)


@pytest.mark.parametrize(
    ("old", "new", "key", "message"),
    [
        (
            "limits = { A = 0.06, B = 0.2 }",
            "limits = { A = -0.06, B = 0.2 }",
            "figures.arw.limits.A",
            "> 0",
        ),
        (
            "limits = { A = 0.06, B = 0.2 }",
            "limits = { A = 0.06, C = 0.2 }",
            "figures.arw.limits.C",
            "unknown key",
        ),
        ('unit = "deg/sqrt(h)"', 'unit = "deg/h"', "figures.arw.unit", "not a unit of"),
        ("duration_s = 2400.0", "duraton_s = 2400.0", "test.duraton_s", "unknown key"),
        (
            'rule = "guard-banded"',
            'rule = "lenient"',
            "grading.rule",
            "strict, guard-banded, simple",
        ),
        ("confidence = 0.95", "confidence = 95", "grading.confidence", "[0.5, 1)"),
        ("[figures.bias]", "[figures.bias_drift]", "figures.bias_drift", "unknown figure"),
        ("warmup_s = 60.0", "warmup_s = 9000.0", "test.warmup_s", "not shorter"),
        ('axes = ["x"]', "axes = []", "test.axes", "non-empty array"),
        ('model = "TG-1"', "model = 5", "model", "non-empty string"),
    ],
)
def test_errors_name_file_line_and_key(
    tmp_path: Path, old: str, new: str, key: str, message: str
) -> None:
    assert old in BASE
    text = BASE.replace(old, new, 1)
    path = tmp_path / "broken.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ProfileError) as info:
        load_profile(path)
    err = info.value
    assert isinstance(err, StationError) and isinstance(err, ValueError)
    assert err.key == key and err.path == str(path)
    assert err.line == _line_of(text, new.split("=")[0].strip() if "[" not in new[:1] else new)
    assert str(err).startswith(f"{path}:{err.line}: key '{key}'")
    assert message in str(err)


def test_missing_table_and_syntax_error() -> None:
    no_test = re.sub(r"\[test\].*?\n\n", "", BASE, flags=re.DOTALL)
    with pytest.raises(ProfileError, match="key 'test': missing table"):
        parse_profile(no_test, path="p.toml")
    with pytest.raises(ProfileError) as info:
        parse_profile(BASE.replace('rule = "guard-banded"', "rule = guard-banded"), path="p.toml")
    assert info.value.line == _line_of(BASE, "rule =") and "not valid TOML" in str(info.value)


def test_a_profile_without_limits_is_refused() -> None:
    text = profile_text(figures='\n[figures.arw]\nunit = "deg/sqrt(h)"\n')
    with pytest.raises(ProfileError, match="nothing to grade"):
        parse_profile(text, path="p.toml")
