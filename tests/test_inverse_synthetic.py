"""``run_inverse`` end to end on synthetic trials written as a user's files.

A known leg motion gives exact joint centres, heel and toe (Pinocchio forward kinematics of
the shipped leg); a known ground reaction is written as an OpenSim MOT (Y-up, 1000 Hz,
unnamed plates, one of them under the other foot). The pipeline reads the files, filters,
fits the IK, differentiates, assigns plates and runs the inverse dynamics; its moments must
equal those of the exact motion and load. The RNEA itself is checked against the thesis'
Newton-Euler equations in test_inverse.py; here every other step is on trial: file axes
and units, plate-to-foot assignment, COP, resampling, filtering, IK, differentiation, the
time shift, and (in the static case, by hand statics) the clinical signs.
"""

import numpy as np
import pinocchio as pin
import pytest

from predgait.data import read_grf_mot, read_trc, write_csv, write_storage
from predgait.data.frames import OPENSIM_TO_LAB
from predgait.dynamics.external import Load
from predgait.dynamics.inverse import leg_inverse_dynamics
from predgait.dynamics.inverse_options import (
    InverseOptions,
    bundled_options,
    subject01_points,
    with_options,
)
from predgait.dynamics.inverse_trial import bundled_inverse, run_inverse
from predgait.errors import InputError
from predgait.kinematics import clinical
from predgait.models.loading import load_model
from predgait.simulations import synthetic_trials
from predgait.simulations.synthetic_trials import SyntheticWalk

POINTS = {"hip": "hip_center", "knee": "knee_center", "ankle": "ankle_center", "heel": "heel",
          "toe": "toe"}
MARKER_NAMES = {name: name for name in POINTS}   # the CSV names its markers after the points
MARKER_RATE, PLATE_RATE = 100.0, 1000.0
STANCE = (0.6, 1.6)        # s, loaded window of the analysed foot
SPEED = 0.6                # m/s, progression of the whole leg along +X


def leg_motion(t):
    """Smooth coordinates (n, 5) and exact derivatives; content below 2 Hz, knee flexed."""
    return synthetic_trials.leg_motion(t, SyntheticWalk(cadence=0.8, speed=SPEED))


def frame_positions(model, q):
    """Lab positions (n, 3) of the marker frames at each configuration."""
    return synthetic_trials.frame_positions(model, q)


def ground_reaction(t, heel, toe):
    """Force (n, 3) N, COP (n, 3) m (rolling heel to toe, on z = 0), free moment (n, 3)."""
    s = np.clip((t - STANCE[0]) / (STANCE[1] - STANCE[0]), 0.0, 1.0)
    window = np.where((t > STANCE[0]) & (t < STANCE[1]), np.sin(np.pi * s) ** 2, 0.0)
    force = np.column_stack([150 * window * np.cos(np.pi * s), np.zeros_like(t), 750 * window])
    cop = heel + s[:, None] * (toe - heel)
    cop[:, 2] = 0.0
    free = np.column_stack([np.zeros_like(t), np.zeros_like(t), 3.0 * window])
    return force, cop, free


def write_markers_csv(path, time, positions, *, rotation=None):
    rotation = np.eye(3) if rotation is None else rotation
    columns = {name: positions[frame] @ rotation.T for name, frame in POINTS.items()}
    write_csv(path, time, columns, units={n: "m" for n in columns})


def write_grf_mot(path, time, plates, *, rotation=None):
    """Lab-frame plates (force, cop, free) -> an OpenSim MOT (Y-up), prefixes '', '1_', ..."""
    rotation = np.eye(3) if rotation is None else rotation
    to_file = OPENSIM_TO_LAB.T
    columns = {}
    for i, (force, cop, free) in enumerate(plates):
        prefix = f"{i}_" if i else ""
        for stem, values in (("ground_force_v", force), ("ground_force_p", cop),
                             ("ground_torque_", free)):
            values = values @ rotation.T @ to_file.T
            for axis, column in zip("xyz", values.T, strict=True):
                columns[f"{prefix}{stem}{axis}"] = column
    write_storage(path, time, columns, name="synthetic_grf")


def synthetic_trial(tmp_path, *, rotation=None):
    """Write the trial (markers.csv, grf.mot, leg.urdf); return options and the exact answer."""
    model = load_model("leg")
    (tmp_path / "leg.urdf").write_text(model.urdf)
    t = np.arange(0.0, 2.4 + 1e-9, 1 / MARKER_RATE)
    q, v, a = leg_motion(t)
    write_markers_csv(tmp_path / "markers.csv", t, frame_positions(model, q), rotation=rotation)
    t_plate = np.arange(0.0, 2.4 + 1e-9, 1 / PLATE_RATE)
    feet = frame_positions(model, leg_motion(t_plate)[0])
    ours = ground_reaction(t_plate, feet["heel"], feet["toe"])
    # The other foot: loaded 0.55 m behind, over an overlapping window (must be ignored).
    other = tuple(np.array(x) for x in ground_reaction(t_plate - 0.7, feet["heel"] - [0.55, 0, 0],
                                                       feet["toe"] - [0.55, 0, 0]))
    write_grf_mot(tmp_path / "grf.mot", t_plate, [other, ours], rotation=rotation)
    exact_grf = ground_reaction(t, *(frame_positions(model, q)[n] for n in ("heel", "toe")))
    loads = [[Load("foot", f, point=c, moment=m)] for f, c, m in zip(*exact_grf, strict=True)]
    exact = leg_inverse_dynamics(model, q, v, a, loads)
    options = InverseOptions(markers=tmp_path / "markers.csv", grf=tmp_path / "grf.mot",
                             mass=72.6, model=tmp_path / "leg.urdf", points=MARKER_NAMES)
    return options, dict(t=t, q=q, force=exact_grf[0], cop=exact_grf[1],
                         moments=clinical.clinical_moments(exact.tau, exact.hip_moment[:, 1]))


def interior(result, t):
    """Indices of result frames on the exact time grid, away from the filter's edges."""
    lab_time = result.time + result.provenance["time_zero_s"]
    np.testing.assert_allclose(lab_time, t, atol=1e-9)
    keep = np.zeros(t.size, dtype=bool)
    keep[15:-15] = True
    return keep


def test_moments_of_a_known_motion_and_load(tmp_path):
    options, exact = synthetic_trial(tmp_path)
    result = run_inverse(options)
    keep = interior(result, exact["t"])
    np.testing.assert_allclose(result.q[keep], exact["q"][keep], atol=2e-4)
    loaded = keep & (exact["force"][:, 2] > 100)     # away from the contact threshold
    swing = keep & (exact["force"][:, 2] == 0) & (result.grf[:, 2] == 0)
    assert loaded.sum() > 60 and swing.sum() > 60
    np.testing.assert_allclose(result.grf[loaded], exact["force"][loaded], atol=4.0)
    np.testing.assert_allclose(result.cop[loaded, 0], exact["cop"][loaded, 0], atol=2e-3)
    for name, value in result.clinical_moments().items():
        truth = exact["moments"][name]
        scale = np.abs(truth[keep]).max()
        assert scale > 5, name
        error = np.abs(value - truth)
        # Measured: 0.7 / 0.3 / 0.4 N m (hip / knee / ankle) against peaks of 191 / 43 / 59.
        assert error[loaded].max() < 0.01 * scale + 0.3, (name, error[loaded].max(), scale)
        assert error[swing].max() < 0.01 * scale + 0.3, (name, error[swing].max(), scale)
    # Events where the sin^2 ramp crosses the contact threshold (10 N: 37 ms inside).
    ramp = np.arcsin(np.sqrt(options.threshold / 750)) / np.pi * (STANCE[1] - STANCE[0])
    t0 = result.provenance["time_zero_s"]
    assert t0 == pytest.approx(STANCE[0] + ramp, abs=1.5 / MARKER_RATE)
    toe_off = t0 + result.events.toe_offs[result.events.toe_offs > 0][0]
    assert toe_off == pytest.approx(STANCE[1] - ramp, abs=1.5 / MARKER_RATE)


def test_the_other_feet_plate_is_not_applied(tmp_path):
    """The other foot's load alone: no contact under the analysed foot, a clear error."""
    options, _ = synthetic_trial(tmp_path)
    plates = read_grf_mot(options.grf)
    assert len(plates) == 2
    zero = np.zeros((plates[0].time.size, 3))
    other = (plates[0].force, plates[0].cop, plates[0].free_moment)
    write_grf_mot(tmp_path / "only_other.mot", plates[0].time, [other, (zero, zero, zero)])
    with pytest.raises(InputError, match="no plate has a contact"):
        run_inverse(with_options(options, grf=tmp_path / "only_other.mot"))


def statics(model, q, force, cop):
    """Clinical moments of a leg at rest, by hand: moment balance of the segments below each
    joint (foot; foot + shank; whole leg) with the ground reaction and segment weights."""
    pm = model.pin_model
    data = pm.createData()
    pin.framesForwardKinematics(pm, data, q)
    g = np.array([0.0, 0.0, -model.gravity])
    weights = []
    for joint in range(1, pm.njoints):     # foot (root), shank (ankle), thigh (knee)
        inertia = pm.inertias[joint]
        weights.append((data.oMi[joint].act(inertia.lever), inertia.mass * g))
    centre = {j: data.oMf[model.frame_id(f"{j}_center")].translation
              for j in ("ankle", "knee", "hip")}

    def moment_y(point, n_segments):
        total = np.cross(cop - point, force)
        for com, weight in weights[:n_segments]:
            total = total + np.cross(com - point, weight)
        return total[1]

    # The proximal segment's moment M on the distal part balances the loads below:
    # M + sum(r x F) = 0. Dorsiflexion/knee-flexion/hip-flexion moment = -M / +M / -M with
    # +Y toward toe-down for the foot, knee extension for the shank, hip extension for the
    # thigh (docs/DEVELOPING.md, predgait.kinematics.clinical).
    return {"ankle_dorsiflexion_moment": moment_y(centre["ankle"], 1),
            "knee_flexion_moment": -moment_y(centre["knee"], 2),
            "hip_flexion_moment": moment_y(centre["hip"], 3)}, centre


def test_standing_still_gives_hand_statics_and_clinical_signs(tmp_path):
    """A still, flexed leg (loading response): COP ahead of the ankle and the hip, behind
    the knee."""
    model = load_model("leg")
    (tmp_path / "leg.urdf").write_text(model.urdf)
    q0 = np.array([0.2, 0.0703, 0.0, 0.25, -0.45])   # foot flat on z = 0, knee flexed 26 deg
    t = np.arange(0.0, 1.5 + 1e-9, 1 / MARKER_RATE)
    q = np.repeat(q0[None], t.size, axis=0)
    positions = frame_positions(model, q)
    write_markers_csv(tmp_path / "markers.csv", t, positions)
    force = np.array([0.0, 0.0, 400.0])
    cop = positions["ankle_center"][0] + [0.08, 0.0, 0.0]
    cop[2] = 0.0
    t_plate = np.arange(0.0, 1.5 + 1e-9, 1 / PLATE_RATE)
    n = t_plate.size
    write_grf_mot(tmp_path / "grf.mot", t_plate,
                  [(np.tile(force, (n, 1)), np.tile(cop, (n, 1)), np.zeros((n, 3)))])
    expected, centre = statics(model, q0, force, cop)
    assert centre["ankle"][0] < cop[0] < centre["knee"][0]
    assert centre["hip"][0] < cop[0]
    result = run_inverse(InverseOptions(markers=tmp_path / "markers.csv",
                                        grf=tmp_path / "grf.mot", mass=72.6,
                                        model=tmp_path / "leg.urdf", points=MARKER_NAMES))
    # Plantarflexor (reaction ahead of the ankle), knee extensor (behind the knee), hip
    # extensor (ahead of the hip): the internal moments that resist the reaction's turn.
    assert expected["ankle_dorsiflexion_moment"] < -20
    assert expected["knee_flexion_moment"] < -5
    assert expected["hip_flexion_moment"] < -5
    middle = slice(20, -20)
    for name, value in result.clinical_moments().items():
        np.testing.assert_allclose(value[middle], expected[name], atol=1e-6 * 400, err_msg=name)
    angles = result.clinical_angles()
    assert np.degrees(angles["knee_flexion"][middle]) == pytest.approx(np.degrees(0.45))
    assert np.degrees(angles["hip_flexion"][middle]) == pytest.approx(np.degrees(0.2))


def shifted_copy(tmp_path, offset, *, keep_names=True):
    """The bundled subject01 trial moved by ``offset`` (m, lab frame), as CSV + MOT (+XML)."""
    options = bundled_options("right")
    markers = read_trc(options.markers)
    columns = {name: markers.xyz[:, i, :] + offset for i, name in enumerate(markers.names)}
    write_csv(tmp_path / "walk.csv", markers.time, columns, units={n: "m" for n in columns})
    plates = read_grf_mot(options.grf)   # unnamed: prefixes '', '1_' in file order
    write_grf_mot(tmp_path / "walk_grf.mot", plates[0].time,
                  [(p.force, p.cop + offset, p.free_moment) for p in plates])
    xml = options.grf.with_suffix(".xml")
    if keep_names:
        (tmp_path / "walk_grf.xml").write_text(xml.read_text())
    return with_options(options, markers=tmp_path / "walk.csv", grf=tmp_path / "walk_grf.mot")


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (3.0, -1.2, 0.0), (-2.0, 0.5, 0.15)],
                         ids=["same", "horizontal", "horizontal+vertical"])
def test_moving_the_lab_origin_changes_nothing(tmp_path, offset):
    """Markers and plates moved together: same moments (the static trial stays put, it only
    gives segment lengths and cluster offsets, both independent of the origin)."""
    options = shifted_copy(tmp_path, np.array(offset))
    moved = run_inverse(options)
    reference = bundled_inverse("right")
    assert moved.provenance["time_zero_s"] == pytest.approx(reference.provenance["time_zero_s"],
                                                            abs=1e-6)   # CSV: 10 digits
    for name, value in reference.clinical_moments().items():
        np.testing.assert_allclose(moved.clinical_moments()[name], value, atol=1e-5,
                                   err_msg=name)


@pytest.mark.parametrize("side", ["right", "left"])
def test_plates_found_by_position_equal_the_named_ones(tmp_path, side):
    """Without OpenSim's ExternalLoads XML, each contact goes to the foot it lies under."""
    options = shifted_copy(tmp_path, np.zeros(3), keep_names=False)
    options = with_options(options, side=bundled_options(side).side,
                           points=subject01_points(side))
    by_position = run_inverse(options)
    named = bundled_inverse(side)
    np.testing.assert_allclose(by_position.grf, named.grf, atol=1e-6)
    for name, value in named.clinical_moments().items():
        np.testing.assert_allclose(by_position.clinical_moments()[name], value, atol=1e-6)


def test_walking_toward_minus_x_gives_the_same_moments(tmp_path):
    forward = tmp_path / "forward"
    backward = tmp_path / "backward"
    forward.mkdir()
    backward.mkdir()
    half_turn = np.diag([-1.0, -1.0, 1.0])
    options, _ = synthetic_trial(forward)
    turned, _ = synthetic_trial(backward, rotation=half_turn)
    a, b = run_inverse(options), run_inverse(turned)
    for name, value in a.clinical_moments().items():
        np.testing.assert_allclose(b.clinical_moments()[name], value, atol=1e-3 * 100)
