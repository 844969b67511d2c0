"""Bundled data access, time shifting, plate filtering, time-base checks."""

import numpy as np
import pytest

from predgait.data import (
    ForcePlate,
    bundled_path,
    detect_events,
    filter_plate,
    load_subject01,
    read_trc,
    uniform_time,
)
from predgait.errors import InputError


def test_bundled_files_and_bad_name():
    folder = bundled_path("subject01_walk1")
    names = {p.name for p in folder.iterdir()}
    assert {"subject01_walk1.trc", "subject01_walk1_grf.mot", "subject01_walk1_grf.xml",
            "README.md"} <= names
    assert not list(folder.parent.rglob("*.c3d"))  # the 1.1 MB C3D is not shipped
    assert bundled_path("winter_a1/BSP_DempsterWinter.txt").is_file()
    with pytest.raises(InputError, match="datasets: moco_2d_walking, subject01_walk1, winter_a1"):
        bundled_path("nope")


def test_uniform_time_check():
    t = np.round(np.arange(151) / 60, 3)  # 3 decimals, as in the subject01 TRC
    assert np.allclose(uniform_time(t, 60.0), np.arange(151) / 60)
    t_dropped = np.delete(np.arange(152) / 60, 50)
    with pytest.raises(InputError, match="frame 51 reads"):
        uniform_time(t_dropped, 60.0, source="x.trc")


def test_trc_non_numeric_value(tmp_path):
    text = bundled_path("subject01_walk1/subject01_walk1.trc").read_text().splitlines()
    fields = text[10].split("\t")
    fields[5] = "12.3x"
    text[10] = "\t".join(fields)
    path = tmp_path / "bad.trc"
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(InputError, match=r"bad.trc: line 11 has a non-numeric value '12.3x'"):
        read_trc(path)


def test_shift_time_to_heel_strike():
    trial = load_subject01()
    events = detect_events(trial.plate("right"), "right")
    t0 = events.heel_strikes[0]
    shifted, ev = trial.shifted(t0), events.shifted(t0)
    assert ev.heel_strikes[0] == 0.0
    assert ev.cycles()[0][1] == pytest.approx(1.852 - 0.617, abs=0.005)
    assert shifted.markers.time[0] == pytest.approx(-t0)
    assert shifted.plate("right").time[0] == pytest.approx(-t0)
    with pytest.raises(InputError, match="Available plates: right, left"):
        trial.plate("middle")


def test_filter_plate_keeps_contact_and_finite_cop():
    t = np.arange(0, 1, 0.001)
    fz = np.where((t > 0.2) & (t < 0.8), 700 * np.sin(np.pi * (t - 0.2) / 0.6), 0.0) + 1.5
    force = np.column_stack([np.zeros_like(t), np.zeros_like(t), fz])
    cop = np.column_stack([t, np.full_like(t, 0.1), np.zeros_like(t)])
    plate = ForcePlate(t, force, cop, np.zeros_like(force), "p")
    out = filter_plate(plate, 20.0)
    assert np.isfinite(out.cop).all()
    assert np.all(out.force[(t < 0.15) | (t > 0.85)] == 0)  # swing noise removed
    stance = (t > 0.3) & (t < 0.7)
    assert np.allclose(out.cop[stance, 0], t[stance], atol=1e-3)  # linear COP path kept
    assert out.force[:, 2].max() == pytest.approx(700, rel=0.01)
