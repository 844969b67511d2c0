"""The result folder of ``predgait inverse``: what the files hold, and whole-or-nothing."""

import json

import numpy as np
import pytest

from predgait.data import read_storage
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.errors import InputError
from predgait.workflows import inverse_io
from predgait.workflows.inverse_io import result_columns, write_inverse_outputs


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    result = bundled_inverse("right")
    out = write_inverse_outputs(result, tmp_path_factory.mktemp("inv") / "out")
    return result, out


def read_csv(path):
    lines = path.read_text().splitlines()
    comments = [ln for ln in lines if ln.startswith("#")]
    header = next(ln for ln in lines if not ln.startswith("#")).split(",")
    data = np.loadtxt(path, delimiter=",", comments="#", skiprows=len(comments) + 1)
    return comments, {name: data[:, i] for i, name in enumerate(header)}


def test_tables_hold_the_result_in_si_units(written):
    result, out = written
    kinematics, kinetics = result_columns(result)
    for stem, expected in (("kinematics", kinematics), ("inverse_dynamics", kinetics)):
        sto = read_storage(out / f"{stem}.sto")
        assert not sto.in_degrees
        assert "heel strike" in sto.header["time_zero"]
        assert sto.header["units"].startswith("SI")
        np.testing.assert_allclose(sto.time, result.time, atol=1e-9)
        comments, csv = read_csv(out / f"{stem}.csv")
        np.testing.assert_allclose(csv["time"], result.time, atol=1e-9)
        assert set(sto.columns) == set(expected) == set(csv) - {"time"}
        for name, value in expected.items():
            scale = max(np.abs(value).max(), 1.0)
            np.testing.assert_allclose(sto.column(name), value, rtol=0, atol=1e-9 * scale)
            np.testing.assert_allclose(csv[name], value, rtol=0, atol=1e-9 * scale)
        units = comments[1]
        assert "knee_flexion_moment=N m" in units or stem == "kinematics"
        assert "knee_flexion=rad" in units or stem == "inverse_dynamics"
        assert "mass_kg=72.6" in comments[0]
    # Angles in radians: a knee swinging to ~62 deg reads ~1.08, not 62.
    knee = read_storage(out / "kinematics.sto").column("knee_flexion")
    assert 0.9 < knee.max() < 1.3


def test_powers_in_the_file_are_moment_times_angular_velocity(written):
    """Independent of the pipeline's v: differentiate the written angles."""
    _, out = written
    angles = read_storage(out / "kinematics.sto")
    kinetics = read_storage(out / "inverse_dynamics.sto")
    for joint in ("hip_flexion", "knee_flexion", "ankle_dorsiflexion"):
        rate = np.gradient(angles.column(joint), angles.time)
        power = kinetics.column(f"{joint}_power")
        estimate = kinetics.column(f"{joint}_moment") * rate
        inner = slice(2, -2)
        assert np.corrcoef(power[inner], estimate[inner])[0, 1] > 0.995, joint
        assert np.abs(power - estimate)[inner].max() < 0.05 * np.abs(power).max() + 1.0, joint


def test_push_off_generates_power(written):
    """Winter's A2 burst: ankle power generation in late stance (here 2.3 W/kg at 59 %)."""
    result, out = written
    kinetics = read_storage(out / "inverse_dynamics.sto")
    cycle = result.first_cycle()[1]
    toe_off = result.events.toe_offs[result.events.toe_offs > 0][0]
    stance = (kinetics.time >= 0) & (kinetics.time <= toe_off)
    power = kinetics.column("ankle_dorsiflexion_power")[stance] / result.body_mass
    peak = int(np.argmax(power))
    assert 1.0 < power[peak] < 5.0
    assert 0.45 < kinetics.time[stance][peak] / cycle < 0.65
    generated = np.trapezoid(np.clip(power, 0, None), kinetics.time[stance])
    assert 0.1 < generated < 0.5      # J/kg; OpenSim's results of this trial give 0.18


def test_summary_matches_the_tables(written):
    result, out = written
    summary = json.loads((out / "summary.json").read_text())
    kinetics = read_storage(out / "inverse_dynamics.sto")
    cycle_end = result.first_cycle()[1]
    window = (kinetics.time >= -1e-9) & (kinetics.time <= cycle_end + 1e-9)
    for name in ("hip_flexion_moment", "knee_flexion_moment", "ankle_dorsiflexion_moment"):
        values = kinetics.column(name)[window] / 72.6
        peaks = summary["peak_moments_n_m_per_kg"]
        assert peaks[f"{name}_min"] == pytest.approx(values.min(), abs=1e-6)
        assert peaks[f"{name}_max"] == pytest.approx(values.max(), abs=1e-6)
    assert summary["heel_strikes_s"][0] == 0.0
    assert summary["heel_strikes_s"][1] == pytest.approx(cycle_end)
    assert summary["provenance"]["mass_kg"] == 72.6
    assert summary["ik_frames_not_converged"] == 0


def test_a_failed_write_leaves_nothing_behind(tmp_path, monkeypatch):
    result = bundled_inverse("right")

    def broken_plots(result, folder):
        (folder / "angles.png").write_bytes(b"half a file")
        raise OSError("disk full")

    monkeypatch.setattr(inverse_io, "save_gait_plots", broken_plots)
    out = tmp_path / "out"
    with pytest.raises(OSError, match="disk full"):
        write_inverse_outputs(result, out)
    assert list(tmp_path.iterdir()) == []          # no folder, no staging left-overs
    out.mkdir()
    (out / "kept.txt").write_text("earlier results")
    with pytest.raises(OSError, match="disk full"):
        write_inverse_outputs(result, out, force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert [p.name for p in out.iterdir()] == ["kept.txt"]
    assert (out / "kept.txt").read_text() == "earlier results"


def test_never_writes_over_its_inputs(tmp_path):
    result = bundled_inverse("right")
    trial = tmp_path / "lab" / "walk.trc"
    trial.parent.mkdir()
    trial.write_text("markers")
    with pytest.raises(InputError, match="holds the input"):
        write_inverse_outputs(result, tmp_path / "lab", force=True, inputs=[trial])
    assert trial.read_text() == "markers"
    with pytest.raises(InputError, match="add --force"):
        write_inverse_outputs(result, tmp_path / "lab", inputs=[trial])
