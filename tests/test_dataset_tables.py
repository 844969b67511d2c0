"""The tidy cycle table and the mean +- SD curves of a dataset (issue 31), on known signals."""

import math

import numpy as np
import pytest

from predgait.errors import InputError
from predgait.report.dataset_tables import (
    ALL,
    TIDY,
    cycle_rows,
    mean_curves,
    read_normative,
    read_rows,
    write_rows,
)


def rows_of(trial: str, subject: str, amplitude: float, *, flag_cycle: int | None = None):
    """Two 1 s cycles of ``amplitude * sin(2 pi t)`` (100 Hz); one cycle may hold a NaN."""
    time = np.arange(0.0, 2.0 + 1e-9, 0.01)
    values = amplitude * np.sin(2 * np.pi * time)
    if flag_cycle is not None:
        values[int((flag_cycle - 0.5) * 100)] = np.nan
    key = {"subject": subject, "condition": "c", "trial": trial, "analysis": "leg",
           "side": "right"}
    return cycle_rows(key, time, [(0.0, 1.0), (1.0, 2.0)], {"knee_flexion": (values, "deg")})


def as_dicts(rows):
    return [dict(zip(TIDY, r, strict=True)) for r in rows]


def test_cycles_are_resampled_to_percent_and_flagged(tmp_path):
    rows = rows_of("t1", "s1", 10.0, flag_cycle=2)
    assert len(rows) == 2 * 101
    first = [r for r in as_dicts(rows) if r["cycle"] == 1]
    np.testing.assert_allclose([r["value"] for r in first],
                               10 * np.sin(2 * np.pi * np.arange(101) / 100), atol=0.02)
    assert {r["flagged"] for r in as_dicts(rows) if r["cycle"] == 2} == {1}
    assert {r["flagged"] for r in first} == {0}
    write_rows(tmp_path / "t.csv", TIDY, rows)   # round trip, NaN as an empty cell
    back = read_rows(tmp_path / "t.csv")
    assert [r["percent"] for r in back[:3]] == [0, 1, 2]
    assert sum(math.isnan(r["value"]) for r in back) == sum(math.isnan(r[8]) for r in rows)


def test_mean_and_sd_over_cycles_leave_flagged_cycles_out():
    rows = as_dicts(rows_of("t1", "s1", 10.0, flag_cycle=2) + rows_of("t2", "s1", 20.0)
                    + rows_of("t3", "s2", 30.0))
    curves = {(c[0], c[6]): c for c in mean_curves(rows)}
    # s1 at 25 %: cycles 10 (t1 cycle 1), 20, 20 (t2): mean 16.67, SD 5.77; n = 3.
    subject, *_, mean, sd, n = curves[("s1", 25)]
    assert (mean, n) == (pytest.approx(50 / 3, abs=0.05), 3)
    assert sd == pytest.approx(np.std([10, 20, 20], ddof=1), abs=0.05)
    _, *_, mean, sd, n = curves[(ALL, 25)]   # with s2's two cycles of 30
    assert (mean, n) == (pytest.approx(110 / 5, abs=0.05), 5)


def test_normative_band_file(tmp_path):
    good = tmp_path / "band.csv"
    good.write_text("# from a lab\nvariable,percent,mean,sd\nknee_flexion,50,40,5\n"
                    "knee_flexion,0,5,3\n")
    percent, mean, sd = read_normative(good)["knee_flexion"]
    assert list(percent) == [0, 50] and list(mean) == [5, 40] and list(sd) == [3, 5]
    for text, message in (("variable,percent,mean\nk,0,1\n", "needs the columns"),
                          ("variable,percent,mean,sd\nk,0,x,1\n", "must be numbers"),
                          ("variable,percent,mean,sd\nk,0,1,-1\n", "sd >= 0")):
        bad = tmp_path / "bad.csv"
        bad.write_text(text)
        with pytest.raises(InputError, match=message):
            read_normative(bad)
