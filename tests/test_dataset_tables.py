"""The tidy cycle table and the mean +- SD curves of a dataset (issue 31), on known signals."""

import csv
import math

import numpy as np
import pytest

from predgait.errors import InputError
from predgait.report.dataset_tables import (
    ALL,
    cycles_of,
    mean_curves,
    read_cycles,
    read_normative,
    write_cycles,
)


def rows_of(trial: str, subject: str, amplitude: float, *, flag_cycle: int | None = None):
    """Two 1 s cycles of ``amplitude * sin(2 pi t)`` (100 Hz); one cycle may hold a NaN."""
    time = np.arange(0.0, 2.0 + 1e-9, 0.01)
    values = amplitude * np.sin(2 * np.pi * time)
    if flag_cycle is not None:
        values[int((flag_cycle - 0.5) * 100)] = np.nan
    key = {"subject": subject, "condition": "c", "trial": trial, "analysis": "leg",
           "side": "right"}
    return cycles_of(key, time, [(0.0, 1.0), (1.0, 2.0)], {"knee_flexion": (values, "deg")})


def test_cycles_are_resampled_to_percent_and_flagged(tmp_path):
    first, second = rows_of("t1", "s1", 10.0, flag_cycle=2)
    np.testing.assert_allclose(first.values, 10 * np.sin(2 * np.pi * np.arange(101) / 100),
                               atol=0.02)
    assert (first.cycle, first.flagged, second.cycle, second.flagged) == (1, False, 2, True)
    assert np.flatnonzero(np.isnan(second.values)).tolist() == [50]   # the flagged frame
    write_cycles(tmp_path, [first, second])      # round trips: the npz and the tidy CSV
    back = read_cycles(tmp_path)
    assert [(c.key, c.cycle, c.variable, c.unit, c.flagged) for c in back] == \
        [(c.key, c.cycle, c.variable, c.unit, c.flagged) for c in (first, second)]
    np.testing.assert_array_equal(back[1].values, second.values)
    with (tmp_path / "cycles.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 202 and rows[101]["cycle"] == "2" and rows[101]["percent"] == "0"
    values = [float(r["value"]) if r["value"] else math.nan for r in rows]
    np.testing.assert_allclose(values, np.concatenate([first.values, second.values]),
                               rtol=1e-9, atol=1e-12)
    assert {r["flagged"] for r in rows[101:]} == {"1"} and rows[0]["subject"] == "s1"


def test_mean_and_sd_over_cycles_leave_flagged_cycles_out():
    cycles = (rows_of("t1", "s1", 10.0, flag_cycle=2) + rows_of("t2", "s1", 20.0)
              + rows_of("t3", "s2", 30.0))
    curves = {(c[0], c[6]): c for c in mean_curves(cycles)}
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
