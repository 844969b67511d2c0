"""Muscle-tendon lengths and moment arms against OpenSim 4.6's own.

Reference: tests/reference/osim2d/muscle_geometry.csv, written by OpenSim 4.6 itself
(make_reference.py, peer Python): GeometryPath lengths and ``Muscle.computeMomentArm`` of
the 18 muscles of 2D_gait.osim at 200 poses (140 uniform within the coordinate ranges, 40
next to ConditionalPathPoint switches, 20 sweeping the knees through the MovingPathPoints).
"""

import csv
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics.muscle_paths import (
    PathGeometry,
    branch_ranges,
    fit_smooth_paths,
    smooth_paths,
)
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait
from predgait.models.osim_model import build_model

TABLE = Path(__file__).resolve().parent / "reference" / "osim2d" / "muscle_geometry.csv"


@pytest.fixture(scope="module")
def geometry() -> PathGeometry:
    return PathGeometry(build_model(bundled_2d_gait()))


@pytest.fixture(scope="module")
def smooth(geometry):
    return fit_smooth_paths(geometry)


@pytest.fixture(scope="module")
def reference(geometry):
    """Poses (N, n_coordinates), lengths (N, 18), moment arms (N, 18, n), spanned columns."""
    with TABLE.open() as handle:
        rows = list(csv.DictReader(handle))
    names = geometry.coordinate_names
    poses = np.array([[float(r[n]) for n in names] for r in rows])
    lengths = np.array([[float(r[f"{m}.length"]) for m in geometry.muscle_names] for r in rows])
    arms = np.zeros((len(rows), len(geometry.muscle_names), len(names)))
    spans = {}
    for i, m in enumerate(geometry.muscle_names):
        prefix = f"{m}.moment_arm."
        spans[m] = tuple(k[len(prefix):] for k in rows[0] if k.startswith(prefix))
        for c in spans[m]:
            arms[:, i, names.index(c)] = [float(r[prefix + c]) for r in rows]
    return poses, lengths, arms, spans


def test_spanned_coordinates_are_opensims(geometry, reference):
    """The coordinates found from the path's bodies = those OpenSim gives a moment arm."""
    spans = reference[3]
    assert {m: set(s) for m, s in zip(geometry.muscle_names, geometry.spans,
                                      strict=True)} == {m: set(s) for m, s in spans.items()}
    assert geometry.spans[geometry.muscle_names.index("hamstrings_r")] == (
        "hip_flexion_r", "knee_angle_r")
    # OpenSim's example says the gastroc path "does not cross the knee joint"; in this
    # file it runs from femur_r to calcn_r, and OpenSim gives it a knee moment arm too.
    assert geometry.spans[geometry.muscle_names.index("gastroc_l")] == (
        "knee_angle_l", "ankle_angle_l")


def test_exact_lengths_and_moment_arms_match_opensim(geometry, reference):
    poses, lengths, arms, _ = reference
    assert np.abs(geometry.lengths(poses) - lengths).max() < 1e-6          # m (0.001 mm)
    assert np.abs(geometry.moment_arms(poses) - arms).max() < 1e-6          # m


def test_exact_length_of_one_pose_and_a_dict(geometry, reference):
    poses, lengths, _, _ = reference
    pose = dict(zip(geometry.coordinate_names, poses[7], strict=True))
    assert np.allclose(geometry.lengths(pose), lengths[7], atol=1e-9)
    assert geometry.lengths(poses[7]).shape == (18,)


def test_polynomials_match_opensim_within_1_mm(smooth, reference):
    poses, lengths, arms, _ = reference
    fitted_lengths = smooth.lengths(poses.T).T
    fitted_arms = np.moveaxis(smooth.moment_arms(poses.T), -1, 0)
    for i, p in enumerate(smooth.polynomials):
        columns = list(p.columns)
        inside = np.all((poses[:, columns] >= p.opensim_ranges[:, 0]) &
                        (poses[:, columns] <= p.opensim_ranges[:, 1]), axis=1)
        assert inside.sum() >= 140, p.muscle            # most poses lie in the fitted range
        length_error = np.abs(fitted_lengths[inside, i] - lengths[inside, i]).max()
        arm_error = np.abs(fitted_arms[inside, i] - arms[inside, i]).max()
        assert length_error < 1e-3 and arm_error < 1e-3, (p.muscle, length_error, arm_error)
        assert length_error < 0.25e-3, p.muscle          # lengths well inside the goal


def test_branch_ranges_stop_at_large_conditional_jumps(geometry, smooth):
    """vasti and rect_fem switch a point with a length jump of 3.4 and 2.5 mm near 81 and
    84 deg of knee flexion: their fits follow OpenSim up to there; all fits span the
    model's whole coordinate ranges."""
    knee = geometry.coordinate_names.index("knee_angle_r")
    for m, name in enumerate(geometry.muscle_names):
        ranges = branch_ranges(geometry, m)
        full = geometry.ranges[list(geometry.columns(m))]
        assert np.array_equal(smooth.polynomials[m].ranges, full) or np.allclose(
            smooth.polynomials[m].ranges, full, rtol=1e-14, atol=0)
        if name in ("vasti_r", "vasti_l", "rect_fem_r", "rect_fem_l"):
            row = geometry.columns(m).index(knee if name.endswith("_r") else knee - 1)
            assert ranges[row, 0] == pytest.approx(-1.42 if "vasti" in name else -1.45997,
                                                   abs=1e-4)
            assert ranges[row, 1] == full[row, 1]
        else:
            assert np.array_equal(ranges, full), name
    valid = smooth.valid_ranges()
    assert valid["knee_angle_r"][0] == pytest.approx(-1.42, abs=1e-4)
    assert np.allclose(valid["hip_flexion_r"], geometry.ranges[4], rtol=1e-14, atol=0)


def test_beyond_the_switch_the_fit_follows_the_branch_continued(geometry, smooth, reference):
    """Over the whole ranges the fits stay within 1 mm of the path whose conditional points
    are decided inside the branch ranges (no blow-up of the polynomials beyond 81 deg)."""
    poses = reference[0]
    decide = poses.copy()
    for m in range(len(geometry.muscle_names)):
        for row, c in enumerate(geometry.columns(m)):
            decide[:, c] = np.clip(decide[:, c], *branch_ranges(geometry, m)[row])
    exact = geometry.lengths(poses, active_at=decide)
    assert np.abs(smooth.lengths(poses.T).T - exact).max() < 1e-3
    knee = geometry.coordinate_names.index("knee_angle_r")
    deep = poses[:, knee] < -1.5
    assert deep.sum() >= 10                                   # poses beyond the switch


def test_moment_arm_signs(smooth, reference):
    """Hamstrings extend the hip and flex the knee, vasti extend the knee, soleus
    plantarflexes, tibialis anterior dorsiflexes, iliopsoas flexes the hip (within
    gait's hip range), as OpenSim's: knee_angle < 0 is flexion, ankle_angle > 0
    dorsiflexion, so a flexor of the knee has a negative moment arm."""
    poses, _, arms, _ = reference
    names = smooth.coordinate_names
    valid = smooth.valid_ranges()
    fitted = np.all([(poses[:, names.index(n)] >= lo) & (poses[:, names.index(n)] <= hi)
                     for n, (lo, hi) in valid.items()], axis=0)
    poses, arms = poses[fitted], arms[fitted]
    assert len(poses) > 80                        # both knees within 81 deg of flexion
    ours = np.moveaxis(smooth.moment_arms(poses.T), -1, 0)
    gait_hip = np.abs(poses[:, names.index("hip_flexion_r")] - 0.3) < 0.9
    expected = {("hamstrings_r", "hip_flexion_r"): -1, ("hamstrings_r", "knee_angle_r"): -1,
                ("vasti_r", "knee_angle_r"): +1, ("soleus_r", "ankle_angle_r"): -1,
                ("tib_ant_r", "ankle_angle_r"): +1, ("iliopsoas_r", "hip_flexion_r"): +1,
                ("glut_max_r", "hip_flexion_r"): -1, ("gastroc_r", "ankle_angle_r"): -1}
    for (muscle, coordinate), sign in expected.items():
        i, c = smooth.muscle_names.index(muscle), names.index(coordinate)
        rows = gait_hip if "hip" in coordinate else slice(None)
        assert np.all(np.sign(arms[rows, i, c]) == sign), (muscle, coordinate)   # OpenSim
        assert np.all(np.sign(ours[rows, i, c]) == sign), (muscle, coordinate)


def test_casadi_functions_and_speeds(smooth, geometry, reference):
    poses = reference[0]
    lengths, arms = smooth.casadi_functions()
    q = cs.SX.sym("q", len(smooth.coordinate_names))
    jacobian = cs.Function("j", [q], [cs.jacobian(smooth.lengths(q), q)])
    for pose in poses[:20]:
        assert np.allclose(np.asarray(lengths(pose)).ravel(), smooth.lengths(pose),
                           rtol=0, atol=1e-12)
        assert np.allclose(np.asarray(arms(pose)), smooth.moment_arms(pose), atol=1e-12)
        assert np.allclose(-np.asarray(jacobian(pose)), smooth.moment_arms(pose), atol=1e-12)
    # Lengthening speed -R v against the exact geometry's rate along a motion.
    rng = np.random.default_rng(3)
    v = np.zeros(len(smooth.coordinate_names))
    v[3:9] = rng.uniform(-3.0, 3.0, 6)
    pose, dt = poses[1], 1e-6                     # a pose within the fitting ranges
    assert all(lo <= pose[smooth.coordinate_names.index(n)] <= hi
               for n, (lo, hi) in smooth.valid_ranges().items())
    rate = (geometry.lengths(pose + v * dt) - geometry.lengths(pose - v * dt)) / (2 * dt)
    assert np.allclose(smooth.lengthening_speeds(pose, v), rate, atol=3e-3)
    assert np.allclose(np.asarray(smooth.lengthening_speeds(cs.DM(pose), cs.DM(v))).ravel(),
                       smooth.lengthening_speeds(pose, v), atol=1e-12)


def test_model_q_order(smooth, geometry, reference):
    """The same lengths from the model's q (its order, base_pitch = -pelvis_tilt)."""
    built = geometry.built
    on_q = smooth.reordered(built.osim_coordinates, built.signs)
    pose = reference[0][11]
    q = built.q_from_osim(dict(zip(geometry.coordinate_names, pose, strict=True)))
    assert np.allclose(on_q.lengths(q), smooth.lengths(pose), atol=1e-14)
    assert np.allclose(smooth_paths(built, on_model_q=True).lengths(q), on_q.lengths(q),
                       atol=1e-14)                      # the same seeded fit
    assert smooth_paths(built) is smooth_paths(built)    # fitted once per model
    with pytest.raises(InputError, match="spans hip_flexion_r"):
        smooth.reordered(("knee_angle_r",))
