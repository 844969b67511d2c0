"""Readers and writers: round trips, units, axes, and bad input messages."""

import re

import numpy as np
import pytest

from predgait.data import (
    bundled_path,
    read_grf_mot,
    read_markers_csv,
    read_storage,
    read_trc,
    write_csv,
    write_storage,
)
from predgait.errors import InputError

TRC = """PathFileType\t4\t(X/Y/Z)\t{name}
DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames
100.00\t100.00\t{n}\t2\t{units}\t100.00\t1\t{n}
Frame#\tTime\tA\t\t\tB\t\t
\t\tX1\tY1\tZ1\tX2\tY2\tZ2

"""


def _write_trc(path, *, units="mm", n=5, rows=None, sep="\t"):
    text = TRC.format(name=path.name, n=n, units=units)
    for i in range(n if rows is None else rows):
        values = [i + 1, f"{i / 100:.3f}", 10 * i, 1000, 20, "", "", ""] if i == 2 else \
                 [i + 1, f"{i / 100:.3f}", 10 * i, 1000, 20, 1, 2, 3]
        text += sep.join(str(v) for v in values) + "\t\n"
    path.write_text(text)
    return path


@pytest.mark.parametrize("units, factor", [("mm", 1e-3), ("cm", 1e-2), ("m", 1.0)])
def test_trc_units_axes_and_missing(tmp_path, units, factor):
    m = read_trc(_write_trc(tmp_path / "a.trc", units=units))
    assert m.names == ("A", "B") and m.rate == 100.0 and m.n_frames == 5
    # OpenSim (x forward, y up, z right) -> lab (x, -z, y)
    assert np.allclose(m.get("A")[1], np.array([10, -20, 1000]) * factor)
    assert np.isnan(m.get("B")[2]).all() and not np.isnan(m.get("B")[3]).any()
    lab = read_trc(tmp_path / "a.trc", axes="z_up")
    assert np.allclose(lab.get("A")[1], np.array([10, 1000, 20]) * factor)


def test_trc_space_separated(tmp_path):
    path = tmp_path / "s.trc"
    text = TRC.format(name="s", n=3, units="m").replace("\t", " ")
    text += "".join(f"{i + 1} {i / 100} 1 2 3 4 5 6\n" for i in range(3))
    path.write_text(text)
    assert np.allclose(read_trc(path, axes="z_up").get("B"), [[4, 5, 6]] * 3)


def test_trc_truncated_and_missing_file(tmp_path):
    path = _write_trc(tmp_path / "cut.trc", n=5, rows=3)
    with pytest.raises(InputError, match=r"cut.trc: 3 data rows .*NumFrames=5.*truncated"):
        read_trc(path)
    with pytest.raises(InputError, match="nothere.trc: file not found"):
        read_trc(tmp_path / "nothere.trc")


@pytest.mark.parametrize("cut", ["1.2e", "-", ".", "1e+"])
def test_trc_cut_off_number_is_named(tmp_path, cut):
    """A file cut inside a number leaves characters of a number that is none."""
    path = _write_trc(tmp_path / "cut.trc", n=5)
    path.write_text(path.read_text().rstrip("\t\n").rsplit("\t", 1)[0] + "\t" + cut + "\n")
    message = rf"cut.trc: line 11 has a non-numeric value '{re.escape(cut)}'"
    with pytest.raises(InputError, match=message):
        read_trc(path)


def test_missing_marker_lists_available(tmp_path):
    m = read_trc(_write_trc(tmp_path / "a.trc"))
    with pytest.raises(InputError, match=r"no marker named 'C'.*Available markers: A, B"):
        m.get("C")


def test_storage_round_trip_and_refuses_input(tmp_path):
    time = np.linspace(0, 1, 11)
    cols = {"knee": np.sin(time), "grf": np.column_stack([time, 2 * time, 3 * time])}
    out = tmp_path / "out.sto"
    write_storage(out, time, cols, header={"units": "N m"}, in_degrees=True)
    back = read_storage(out)
    assert back.in_degrees and back.header["nRows"] == "11" and back.header["units"] == "N m"
    assert list(back.columns) == ["knee", "grf_x", "grf_y", "grf_z"]
    assert np.allclose(back.time, time) and np.allclose(back.columns["grf_z"], 3 * time)
    assert not list(tmp_path.glob(".*tmp"))  # no temp file left behind
    with pytest.raises(InputError, match="refusing to overwrite an input"):
        write_storage(out, time, cols)
    with pytest.raises(InputError, match="refusing to overwrite an input"):
        write_csv(out, time, cols)


def test_writer_is_atomic_on_bad_column(tmp_path):
    out = tmp_path / "never.sto"
    with pytest.raises(InputError, match="'bad' has 3 rows"):
        write_storage(out, np.arange(5.0), {"bad": np.zeros(3)})
    assert not out.exists() and not list(tmp_path.iterdir())


def test_write_csv_units_line(tmp_path):
    out = tmp_path / "t.csv"
    write_csv(out, [0.0, 0.1], {"moment": [1.0, 2.0], "cop": np.zeros((2, 3))},
              units={"moment": "N m", "cop": "m"}, provenance="trial=x; model=leg")
    lines = out.read_text().splitlines()
    assert lines[0] == "# predgait: trial=x; model=leg"
    assert lines[1] == "# units: time=s, moment=N m, cop_x=m, cop_y=m, cop_z=m"
    assert lines[2] == "time,moment,cop_x,cop_y,cop_z"
    m = read_markers_csv(out, {"P": ("cop_x", "cop_y", "moment")}, units="cm")
    assert np.allclose(m.get("P")[:, 2], [0.01, 0.02]) and m.rate == pytest.approx(10.0)


def test_csv_missing_column_lists_columns(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("time,hip_x,hip_y,hip_z\n0,1,2,3\n0.01,1,2,3\n0.02,1,2,\n")
    m = read_markers_csv(path, {"RHIP": ("hip_x", "hip_y", "hip_z")}, units="mm")
    assert np.allclose(m.get("RHIP")[0], [1e-3, 2e-3, 3e-3]) and np.isnan(m.get("RHIP")[2, 2])
    with pytest.raises(InputError, match=r"no column 'knee_x'. Columns: time, hip_x"):
        read_markers_csv(path, {"RKNE": ("knee_x", "hip_y", "hip_z")})


def test_grf_mot_truncated(tmp_path):
    text = bundled_path("subject01_walk1/subject01_walk1_grf.mot").read_text().splitlines()
    path = tmp_path / "cut.mot"
    path.write_text("\n".join(text[:200]) + "\n")
    with pytest.raises(InputError, match="nRows=1501.*truncated"):
        read_grf_mot(path)
