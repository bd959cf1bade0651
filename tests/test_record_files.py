"""CSV rate records: the file format other commands rely on."""

from __future__ import annotations

import gzip
import math

import numpy as np
import pytest

from station.errors import RecordFormatError
from station.storage.csv_records import read_csv_record, write_csv_record
from station.storage.runs import read_record


def test_round_trip_gzip_with_time_column(tmp_path) -> None:
    rate = np.random.default_rng(0).standard_normal((500, 3))
    path = write_csv_record(tmp_path / "r.csv.gz", rate, 25.0, comment="two\nlines")
    rec = read_record(path)
    assert rec.sample_rate_hz == pytest.approx(25.0)
    assert rec.axis_names == ("gyro_x", "gyro_y", "gyro_z")
    np.testing.assert_array_equal(rec.rate_deg_s, rate)
    assert rec.select("gyro_y").rate_deg_s.shape == (500, 1)
    assert rec.slice_time(4.0).n_samples == 400


def test_units_comments_and_missing_rate(tmp_path) -> None:
    path = tmp_path / "r.csv"
    path.write_text("# a comment\nwx,wy\n0.1,0.2\n# mid-file comment\n0.3,0.4\n")
    with pytest.raises(RecordFormatError, match="--rate"):
        read_csv_record(path)
    rec = read_csv_record(path, sample_rate_hz=10.0, units="rad/s")
    np.testing.assert_allclose(rec.rate_deg_s[:, 0], np.array([0.1, 0.3]) * 180 / math.pi)
    assert rec.n_samples == 2
    with pytest.raises(RecordFormatError, match="unknown rate unit"):
        read_csv_record(path, sample_rate_hz=10.0, units="rpm")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("# only a comment\n", "no header"),
        ("0.1,0.2\n0.3,0.4\n", "header"),
        ("time,x\n0,1\n0.1,2\n0.25,3\n0.35,4\n", "irregular time"),
        ("time,x\n0,1\n0.1,2\n0.1,3\n0.2,4\n", "irregular time"),
        ("time,x\n0,1\n0.1,abc\n", r"bad.csv, line 3: value 2 \('abc'\) is not a number; the "
                                   r"format is 2 numbers per line separated by commas"),
        ("# c\ntime,x\n0,1\n# note\n\n0.1;2\n", r"line 6: 1 value where the lines before have 2"),
        ("time,x\n0,1\n0.1,2,3\n", r"line 3: 3 values where the lines before have 2"),
        ("time,x\n", "no data"),
        ("time,x\n0,nan\n0.1,1\n", "non-finite"),
    ],
)
def test_malformed_files_say_what_is_wrong(tmp_path, text: str, match: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(RecordFormatError, match=match):
        read_csv_record(path)


def test_a_time_column_that_jumps_whole_periods_declares_a_gap(tmp_path) -> None:
    path = tmp_path / "gap.csv"
    path.write_text("time,x\n0,1\n0.1,2\n0.4,3\n0.5,4\n0.6,5\n")
    rec = read_csv_record(path)
    np.testing.assert_array_equal(rec.sample_index, [0, 1, 4, 5, 6])
    assert (rec.n_samples, rec.missing_samples) == (5, 2)
    assert rec.duration_s == pytest.approx(0.7)
    np.testing.assert_array_equal(np.isnan(rec.gridded(0)), [0, 0, 1, 1, 0, 0, 0])
    # --rate that agrees with the time column keeps the gap; one that does not is refused
    assert read_csv_record(path, sample_rate_hz=10.0).missing_samples == 2
    with pytest.raises(RecordFormatError, match=r"steps 0.1 s \(10 Hz\) but --rate says 1000 Hz"):
        read_csv_record(path, sample_rate_hz=1000.0)
    # a slice keeps true time: 0.35 s .. end starts at the first sample after the gap
    part = rec.slice_time(0.35)
    np.testing.assert_array_equal(part.rate_deg_s[:, 0], [3, 4, 5])
    assert part.sample_index is None
    assert rec.slice_time(0.0, 0.52).missing_samples == 2


def test_a_record_with_gaps_survives_a_round_trip(tmp_path) -> None:
    index = np.array([0, 1, 2, 10, 11, 12, 13, 40])
    rate = np.arange(len(index), dtype=float)[:, None]
    path = write_csv_record(tmp_path / "r.csv.gz", rate, 50.0, sample_index=index)
    back = read_record(path)
    np.testing.assert_array_equal(back.sample_index, index)
    assert back.sample_rate_hz == pytest.approx(50.0)


def test_gzip_file_is_read_directly(tmp_path) -> None:
    path = tmp_path / "g.csv.gz"
    with gzip.open(path, "wt") as fh:
        fh.write("time,gyro\n0,1\n0.5,2\n1.0,3\n")
    rec = read_record(path)
    assert rec.sample_rate_hz == pytest.approx(2.0)
    with pytest.raises(FileNotFoundError):
        read_record(tmp_path / "missing.csv")
