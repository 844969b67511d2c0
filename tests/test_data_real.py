"""Real trials: subject01 (OpenSim), walking5.c3d, Winter Table A.1."""

import ezc3d
import numpy as np
import pytest

from predgait.data import (
    detect_events,
    fill_gaps,
    load_subject01,
    load_winter_a1,
    lowpass,
    read_c3d,
    resample_plate,
    residual_analysis,
    subject_info,
)
from predgait.errors import InputError

WALKING5 = "opensim_walking5_c3d/walking5.c3d"


@pytest.fixture(scope="module")
def subject01():
    return load_subject01()


@pytest.fixture(scope="module")
def walking5(shared_data):
    return read_c3d(shared_data / WALKING5)


def test_subject01_markers(subject01):
    m = subject01.markers
    assert m.xyz.shape == (151, 41, 3) and m.rate == 60.0
    assert np.allclose(np.diff(m.time), 1 / 60) and m.time[-1] == pytest.approx(2.5)
    # mm -> m, Y-up -> Z-up: ASIS about 1 m up, right ASIS on the right (lab -Y)
    assert 0.9 < m.get("R.ASIS")[:, 2].mean() < 1.1
    assert m.get("R.ASIS")[0, 1] == pytest.approx(-0.17078198)
    assert m.get("L.ASIS")[0, 1] > 0 and m.get("Top.Head")[:, 2].min() > 1.6
    assert not np.isnan(m.xyz).any()
    assert subject_info("subject01_walk1")["mass"] == 72.6


def test_subject01_plates_and_events(subject01):
    right, left = subject01.plate("right"), subject01.plate("left")
    assert right.time.size == 1501 and right.rate == pytest.approx(600, rel=1e-3)
    assert right.force[:, 2].max() == pytest.approx(804.86, abs=0.1)
    assert left.force[:, 2].max() == pytest.approx(810.84, abs=0.1)
    assert np.allclose(right.cop[:, 2], -0.0075)  # OpenSim py -> lab z
    assert np.all(right.cop[right.force[:, 2] > 20, 1] < 0)  # right foot on the right
    r = detect_events(right, "right")
    assert np.allclose(r.heel_strikes, [0.617, 1.852], atol=0.003)
    assert np.allclose(r.toe_offs, [0.163, 1.408], atol=0.003)
    lft = detect_events(left, "left")
    assert np.allclose(lft.heel_strikes, [1.245, 2.458], atol=0.003)
    assert np.allclose(lft.toe_offs, [0.787, 2.017], atol=0.003)


def test_subject01_kinematic_events_agree_with_plate(subject01):
    m = subject01.markers
    smooth = m.with_xyz(lowpass(m.xyz, m.rate, 6.0))
    e = detect_events(smooth, "right", heel="R.Heel", toe="R.Toe.Tip",
                      pelvis=("R.ASIS", "L.ASIS", "V.Sacral"))
    assert np.allclose(e.heel_strikes, [0.617, 1.852], atol=0.05)
    assert np.allclose(e.toe_offs, [0.163, 1.408], atol=0.05)


def test_subject01_resampled_plate_threshold(subject01):
    m, right = subject01.markers, subject01.plate("right")
    swing = (right.time > 0.2) & (right.time < 0.6)
    assert 0 < np.abs(right.force[swing]).max() < 5  # raw: noise in swing
    at_markers = resample_plate(right, m.time)
    assert at_markers.force.shape == (151, 3)
    mswing = (m.time > 0.2) & (m.time < 0.6)
    assert np.all(at_markers.force[mswing] == 0) and np.all(at_markers.free_moment[mswing] == 0)
    assert np.isfinite(at_markers.cop).all()
    assert at_markers.force[:, 2].max() == pytest.approx(804.86, rel=0.02)
    # frame-averaged impulse equals the raw impulse during the stance
    stance = (m.time > 0.7) & (m.time < 1.3)
    first, last = m.time[stance][[0, -1]]
    raw = (right.time >= first - 1 / 120) & (right.time < last + 1 / 120)
    assert at_markers.force[stance, 2].sum() / 60 == pytest.approx(
        right.force[raw, 2].sum() / 600, rel=0.01)


def test_walking5_markers_and_forward(walking5, shared_data):
    m = walking5.markers
    assert m.xyz.shape == (1103, 40, 3) and m.rate == 250.0
    assert 0.3 < np.isnan(m.xyz[..., 0]).mean() < 0.6
    pelvis = m.get("RASI")
    valid = pelvis[~np.isnan(pelvis[:, 0])]
    assert valid[-1, 0] - valid[0, 0] > 3.0  # walks toward +X in the lab frame
    file_frame = read_c3d(shared_data / WALKING5, forward="+x", plates=False).markers
    assert np.allclose(m.xyz[..., 0], -file_frame.xyz[..., 0], equal_nan=True)
    assert np.allclose(m.xyz[..., 2], file_frame.xyz[..., 2], equal_nan=True)


def test_walking5_gaps(walking5):
    m = walking5.markers.select(["RASI", "LASI"]).window(2.0, 3.5)
    assert not np.isnan(m.xyz).any()  # both visible there: make a 30-frame hole in RASI
    holed = m.xyz.copy()
    holed[100:130, 0] = np.nan
    with pytest.raises(InputError) as err:
        fill_gaps(m.with_xyz(holed), max_gap_frames=20)
    assert "marker 'RASI' is missing in frames 101..130 (t = 2.400..2.516 s" in str(err.value)
    filled = fill_gaps(m.with_xyz(holed), max_gap_seconds=0.2)
    assert np.max(np.abs(filled.xyz - m.xyz)) < 0.005  # m: within 5 mm of the true path
    filled = fill_gaps(walking5.markers.select(["RASI", "LASI", "RPSI", "LPSI"]),
                       max_gap_frames=20, edges="trim")
    assert not np.isnan(filled.xyz).any() and filled.n_frames > 300


def test_walking5_plates_contacts_cop_forces(walking5):
    p1, p2 = walking5.plates
    windows = {}
    for plate in (p1, p2):
        fz = plate.force[:, 2]
        loaded = fz > 30
        windows[plate.name] = plate.time[loaded][[0, -1]]
        assert 500 < fz.max() < 1500
        cop = plate.cop[fz > 0.2 * fz.max()]  # COP is unreliable at light loads
        lo, hi = plate.corners.min(axis=0), plate.corners.max(axis=0)
        assert np.all((cop[:, :2] >= lo[:2] - 0.01) & (cop[:, :2] <= hi[:2] + 0.01))
        assert np.abs(plate.free_moment[loaded, 2]).max() < 20  # N m, not N mm
        assert np.allclose(plate.free_moment[:, :2], 0)
    assert np.allclose(windows["1"], [1.964, 2.470], atol=0.005)
    assert np.allclose(windows["2"], [2.383, 2.968], atol=0.005)


def test_walking5_plates_match_ezc3d(shared_data):
    mine = read_c3d(shared_data / WALKING5, forward="+x")  # file frame: comparable
    ref = ezc3d.c3d(str(shared_data / WALKING5), extract_forceplat_data=True)
    for plate, other in zip(mine.plates, ref["data"]["platform"], strict=True):
        loaded = plate.force[:, 2] > 30
        assert np.allclose(plate.force, other["force"].T, atol=1e-6)
        assert np.allclose(plate.cop[loaded], other["center_of_pressure"].T[loaded] / 1000,
                           atol=1e-6)
        assert np.allclose(plate.free_moment[loaded], other["Tz"].T[loaded] / 1000, atol=1e-6)


def test_winter_table(shared_data):
    w = load_winter_a1()
    assert w.xyz.shape == (106, 8, 3) and w.rate == pytest.approx(69.9)
    assert np.all(w.xyz[:, :, 1] == 0)
    rib = w.get("RIB CAGE")
    assert rib[0, 0] == pytest.approx(0.4698) and rib[-1, 0] > 2.5 and rib[0, 2] == 1.0441
    assert subject_info("winter_a1")["mass"] == 56.7
    result = residual_analysis(w.xyz[:, :, [0, 2]], w.rate)
    assert 4.0 < result.chosen < 9.0  # Winter filtered these data at 6 Hz
    smooth = w.with_xyz(lowpass(w.xyz, w.rate, 6.0))
    e = detect_events(smooth, "right", heel="RIGHT HEEL", toe="RIGHT TOE", pelvis=["RIGHT HIP"])
    # Winter: heel contact frames 28 and 97, toe off frame 70 (1-based)
    assert np.allclose(e.heel_strikes * w.rate + 1, [28, 97], atol=4)
    assert np.allclose(e.toe_offs * w.rate + 1, [70], atol=4)
