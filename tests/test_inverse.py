"""Planar inverse dynamics: thesis Newton-Euler, synthetic known answers, real trials."""

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.external import Load, joint_forces
from predgait.dynamics.inverse import leg_inverse_dynamics
from predgait.dynamics.inverse_options import bundled_options, with_options
from predgait.dynamics.inverse_trial import bundled_inverse, run_inverse
from predgait.kinematics import clinical
from predgait.kinematics.joint_centres import (
    calibrate_centre,
    cluster_frame,
    harrington_hip,
)
from predgait.kinematics.planar_ik import solve_ik
from predgait.kinematics.segment_angles import (
    angular_acceleration,
    angular_velocity,
    segment_angle,
)
from predgait.models.loading import load_model


def smooth_motion(model, n=200, seed=0):
    """Smooth leg coordinates (sums of sines) with exact derivatives."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n)
    amp, freq, phase = rng.uniform(0.05, 0.3, (3, model.nq, 3))
    freq = 2 * np.pi * (0.5 + 1.5 * freq)
    base = np.array([0.1, 0.08, 0.0, 0.1, -0.5])
    q = base + np.sum(amp * np.sin(freq * t[:, None, None] + phase * 6), axis=2)
    v = np.sum(amp * freq * np.cos(freq * t[:, None, None] + phase * 6), axis=2)
    a = -np.sum(amp * freq**2 * np.sin(freq * t[:, None, None] + phase * 6), axis=2)
    return t, q, v, a


def cross2(r, f):
    return r[1] * f[0] - r[0] * f[1]


def test_bottom_up_newton_euler_of_the_thesis():
    """Thesis 3.3.3-3.3.5 from the foot up (ground reaction known) vs RNEA + hip solve."""
    model = load_model("leg")
    pm = model.pin_model
    data = pm.createData()
    t, q, v, a = smooth_motion(model, n=6, seed=1)
    g = np.array([0.0, -model.gravity])
    rng = np.random.default_rng(2)
    for k in range(len(t)):
        f_ground = np.array([rng.uniform(-150, 150), rng.uniform(200, 900)])
        cop = np.array([q[k, 0] + rng.uniform(-0.05, 0.15), 0.0])
        loads = [Load("foot", np.array([f_ground[0], 0, f_ground[1]]),
                      point=np.array([cop[0], 0.0, cop[1]]))]
        inv = leg_inverse_dynamics(model, q[k:k + 1], v[k:k + 1], a[k:k + 1], [loads])
        pin.forwardKinematics(pm, data, q[k], v[k], a[k])
        pin.updateFramePlacements(pm, data)
        seg = {}
        for name in ("foot", "shank", "thigh"):
            fid = model.frame_id(name)
            joint = pm.frames[fid].parentJoint
            inertia = pm.inertias[joint]
            r = data.oMi[joint].rotation @ inertia.lever
            acc = pin.getFrameClassicalAcceleration(pm, data, fid,
                                                    pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            omega = pin.getFrameVelocity(pm, data, fid,
                                         pin.ReferenceFrame.LOCAL_WORLD_ALIGNED).angular
            com_acc = acc.linear + np.cross(acc.angular, r) + np.cross(omega, np.cross(omega, r))
            seg[name] = dict(m=inertia.mass, I=inertia.inertia[1, 1], alpha=acc.angular[1],
                             com=data.oMi[joint].act(inertia.lever)[[0, 2]], acc=com_acc[[0, 2]])
        pos = {n: data.oMf[model.frame_id(n)].translation[[0, 2]]
               for n in ("ankle_center", "knee_center", "hip_center")}
        # Foot: F_A (shank on foot) from m a = F_G + F_A + m g; moment about the COM.
        ft = seg["foot"]
        f_a = ft["m"] * ft["acc"] - ft["m"] * g - f_ground
        m_a = (ft["I"] * ft["alpha"] - cross2(cop - ft["com"], f_ground)
               - cross2(pos["ankle_center"] - ft["com"], f_a))
        sh = seg["shank"]   # -F_A, -M_A at the ankle; F_K, M_K (thigh on shank) at the knee
        f_k = sh["m"] * sh["acc"] - sh["m"] * g + f_a
        m_k = (sh["I"] * sh["alpha"] + m_a - cross2(pos["ankle_center"] - sh["com"], -f_a)
               - cross2(pos["knee_center"] - sh["com"], f_k))
        th = seg["thigh"]
        f_h = th["m"] * th["acc"] - th["m"] * g + f_k
        m_h = (th["I"] * th["alpha"] + m_k - cross2(pos["knee_center"] - th["com"], -f_k)
               - cross2(pos["hip_center"] - th["com"], f_h))
        np.testing.assert_allclose(inv.hip_force[0, [0, 2]], f_h, atol=1e-8)
        np.testing.assert_allclose(inv.hip_moment[0, 1], m_h, atol=1e-8)
        # The joint torque acts on the child (shank at the ankle, thigh at the knee):
        # tau_ankle = -M_A (M_A acts on the foot), tau_knee = -M_K.
        np.testing.assert_allclose(inv.tau[0, 3], -m_a, atol=1e-8)
        np.testing.assert_allclose(inv.tau[0, 4], -m_k, atol=1e-8)
        np.testing.assert_allclose(inv.joint_force["ankle"][0, [0, 2]], f_a, atol=1e-8)
        np.testing.assert_allclose(inv.joint_force["knee"][0, [0, 2]], f_k, atol=1e-8)
        np.testing.assert_allclose(inv.tau[0, :3], 0, atol=1e-8)


def test_forward_then_inverse_recovers_torques_and_hip_load():
    """Random torques, hip load and ground reaction drive ABA; ID on the result returns them."""
    model = load_model("leg")
    pm = model.pin_model
    data = pm.createData()
    t, q, v, _ = smooth_motion(model, n=40, seed=3)
    rng = np.random.default_rng(4)
    tau_true = rng.uniform(-60, 60, (len(t), 2))
    hip_true = np.column_stack([rng.uniform(-100, 100, len(t)), rng.uniform(-700, -300, len(t)),
                                rng.uniform(-40, 40, len(t))])
    a = np.zeros_like(q)
    loads = []
    for k in range(len(t)):
        pin.framesForwardKinematics(pm, data, q[k])
        ground = Load("foot", np.array([rng.uniform(-100, 100), 0, rng.uniform(300, 800)]),
                      point=np.array([q[k, 0] + rng.uniform(-0.05, 0.15), 0.0, 0.0]))
        hip = Load("hip_center", np.array([hip_true[k, 0], 0, hip_true[k, 1]]),
                   moment=np.array([0, hip_true[k, 2], 0]))
        tau = np.concatenate([np.zeros(3), tau_true[k]])
        a[k] = pin.aba(pm, data, q[k], v[k], tau, joint_forces(model, data, [ground, hip]))
        loads.append([ground])
    inv = leg_inverse_dynamics(model, q, v, a, loads)
    np.testing.assert_allclose(inv.tau[:, 3:], tau_true, atol=1e-7)
    np.testing.assert_allclose(inv.hip_force[:, [0, 2]], hip_true[:, :2], atol=1e-7)
    np.testing.assert_allclose(inv.hip_moment[:, 1], hip_true[:, 2], atol=1e-7)
    np.testing.assert_allclose(inv.tau[:, :3], 0, atol=1e-7)


def test_segment_angle_equations_on_a_rotating_segment():
    """3.2.1-3.2.10 are exact on a rigid segment turning through +-90 deg (switching)."""
    t = np.linspace(0, 2, 801)
    theta, omega, alpha = 1.4 * np.sin(2 * t), 2.8 * np.cos(2 * t), -5.6 * np.sin(2 * t)
    lower = np.stack([0.3 * t, 0 * t, 0.5 + 0 * t], 1)
    u = np.stack([np.sin(theta), 0 * t, np.cos(theta)], 1)
    du = np.stack([np.cos(theta), 0 * t, -np.sin(theta)], 1)
    upper = lower + 0.4 * u
    v_lower = np.stack([0.3 + 0 * t, 0 * t, 0 * t], 1)
    v_upper = v_lower + 0.4 * omega[:, None] * du
    a_upper = 0.4 * (alpha[:, None] * du - omega[:, None] ** 2 * u)
    np.testing.assert_allclose(segment_angle(upper, lower), theta, atol=1e-12)
    np.testing.assert_allclose(angular_velocity(upper, lower, v_upper, v_lower), omega,
                               atol=1e-10)
    np.testing.assert_allclose(angular_acceleration(upper, lower, a_upper, 0 * a_upper, omega),
                               alpha, atol=1e-9)
    # A marker sliding along the segment (skin motion) is removed by 3.2.11-3.2.17.
    slide = 0.05 * np.sin(7 * t)[:, None] * u
    v_slide = v_upper + 0.35 * np.cos(7 * t)[:, None] * u + 0.05 * np.sin(7 * t)[:, None] * \
        omega[:, None] * du
    w = angular_velocity(upper + slide, lower, v_slide, v_lower)
    w_raw = angular_velocity(upper + slide, lower, v_slide, v_lower, rigid_correction=False)
    assert np.abs(w_raw - omega).max() > 0.1
    assert np.abs(w - omega).max() < 0.05 * np.abs(omega).max()


def test_harrington_hip_on_an_aligned_pelvis():
    rasis, lasis = np.array([0.1, -0.125, 1.0]), np.array([0.1, 0.125, 1.0])
    sacrum = np.array([-0.05, 0.0, 1.0])
    hip = harrington_hip(rasis, lasis, sacrum, side="right")
    pw, pd = 250.0, 150.0
    expected = np.array([0.1 + (-0.24 * pd - 9.9) / 1000, -(0.33 * pw + 7.3) / 1000,
                         1.0 + (-0.30 * pw - 10.9) / 1000])
    np.testing.assert_allclose(hip, expected, atol=1e-12)
    left = harrington_hip(rasis, lasis, sacrum, side="left")
    np.testing.assert_allclose(left[1], -hip[1])


def test_static_calibration_moves_rigidly_with_the_cluster():
    from predgait.data.trial import Markers

    rng = np.random.default_rng(5)
    cluster = rng.uniform(-0.1, 0.1, (3, 3)) + [0, 0, 0.5]
    medial, lateral = np.array([0.0, 0.05, 0.45]), np.array([0.0, -0.05, 0.45])
    names = ("c1", "c2", "c3", "med", "lat")
    static = Markers(time=[0.0, 0.1], names=names,
                     xyz=np.repeat(np.vstack([cluster, medial, lateral])[None], 2, 0), rate=10)
    centre = calibrate_centre(static, "knee", "med", "lat", ("c1", "c2", "c3"))
    angle = 0.7
    rot = np.array([[np.cos(angle), 0, np.sin(angle)], [0, 1, 0],
                    [-np.sin(angle), 0, np.cos(angle)]])
    shift = np.array([0.3, 0.0, 0.1])
    moved = Markers(time=[0.0], names=names[:3], xyz=(cluster @ rot.T + shift)[None], rate=10)
    np.testing.assert_allclose(centre.locate(moved)[0], rot @ (0.5 * (medial + lateral)) + shift,
                               atol=1e-12)
    origin, frame = cluster_frame(*cluster)
    np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-12)


def test_ik_recovers_known_coordinates():
    model = load_model("leg")
    pm = model.pin_model
    data = pm.createData()
    t, q, _, _ = smooth_motion(model, n=50, seed=6)
    rng = np.random.default_rng(7)
    points = {n: np.zeros((len(t), 3)) for n in ("ankle_center", "knee_center", "hip_center")}
    for k in range(len(t)):
        pin.framesForwardKinematics(pm, data, q[k])
        for n in points:
            points[n][k] = data.oMf[model.frame_id(n)].translation
    exact = solve_ik(model, points, q[:, 2])
    np.testing.assert_allclose(exact.q, q, atol=1e-8)
    assert max(exact.rms().values()) < 1e-9
    noisy = {n: p + rng.normal(0, 0.002, p.shape) for n, p in points.items()}
    fit = solve_ik(model, noisy, q[:, 2])
    assert np.degrees(np.abs(fit.q[:, 3:] - q[:, 3:]).max()) < 2.0
    assert 0.0005 < max(fit.rms().values()) < 0.004


# Real data ---------------------------------------------------------------------------
# Published normal ranges, N m/kg, internal moments: Winter (2009) Biomechanics and Motor
# Control of Human Movement, 4th ed., Fig. 5.? / Appendix A (natural cadence), and
# Kadaba et al. (1989) J Orthop Res 7:849-860 (mean +- 2 SD of 40 adults).
NORMAL_PEAKS = {
    "ankle_dorsiflexion_moment_min": (-2.0, -1.0),   # plantarflexor, push-off
    "knee_flexion_moment_min": (-1.5, -0.2),          # extensor, loading response
    "hip_flexion_moment_min": (-1.5, -0.3),           # extensor, early stance
    "hip_flexion_moment_max": (0.3, 1.5),             # flexor, late stance
}


def peaks(result):
    mask = (result.time >= 0) & (result.time <= result.first_cycle()[1])
    return {f"{k}_{f.__name__}": f(v[mask]) / result.body_mass
            for k, v in result.clinical_moments().items() for f in (np.min, np.max)}


@pytest.mark.parametrize("side", ["right", "left"])
def test_subject01_within_normal_ranges(side):
    result = bundled_inverse(side)
    values = peaks(result)
    for name, (low, high) in NORMAL_PEAKS.items():
        assert low <= values[name] <= high, (side, name, values[name])
    angles = {k: np.degrees(v) for k, v in result.clinical_angles().items()}
    assert 50 < angles["knee_flexion"].max() < 75          # swing peak (Winter: ~65 deg)
    assert 30 < np.ptp(angles["hip_flexion"]) < 55         # sagittal hip excursion
    assert max(result.ik.rms().values()) < 0.01             # joint centres within 1 cm
    cycle = result.first_cycle()
    # Plate contact of the README (vy > 20 N): right 0.617 -> 1.852 s, left 1.245 -> 2.458 s.
    start = result.provenance["time_zero_s"]
    expected = {"right": (0.617, 1.852), "left": (1.245, 2.458)}[side]
    assert start == pytest.approx(expected[0], abs=0.02)
    assert start + cycle[1] == pytest.approx(expected[1], abs=0.02)


def test_left_and_right_mirror():
    right, left = peaks(bundled_inverse("right")), peaks(bundled_inverse("left"))
    for name in NORMAL_PEAKS:
        assert np.sign(right[name]) == np.sign(left[name])
        # Healthy gait is not perfectly symmetric: peak moments differ by up to ~20-30 %
        # between sides (Sadeghi et al. 2000, Gait & Posture 12:34-45).
        assert abs(right[name] - left[name]) < 0.4, name


def test_same_trial_through_csv_gives_the_same_moments(tmp_path):
    from predgait.data import read_trc, write_csv

    options = bundled_options("right")
    markers = read_trc(options.markers)
    columns = {name: markers.xyz[:, i, :] for i, name in enumerate(markers.names)}
    # write_csv stores lab-frame metres; read it back as Z-up lab axes.
    write_csv(tmp_path / "walk.csv", markers.time, columns, units={n: "m" for n in columns})
    via_csv = run_inverse(with_options(options, markers=tmp_path / "walk.csv"))
    via_trc = bundled_inverse("right")
    for name, value in via_trc.clinical_moments().items():
        np.testing.assert_allclose(via_csv.clinical_moments()[name], value, atol=1e-6)


def test_walking5_c3d_both_plates(shared_data):
    from predgait.dynamics.inverse_options import InverseOptions

    results = {}
    for side, s in (("right", "R"), ("left", "L")):
        options = InverseOptions(
            markers=shared_data / "opensim_walking5_c3d" / "walking5.c3d", mass=72.0, side=side,
            points={"hip": f"{s}HJC", "knee": f"{s}KJC", "ankle": f"{s}AJC", "heel": f"{s}CAL",
                    "toe": f"{s}MT2"})
        results[side] = run_inverse(options)
    # README: plate 1 (left foot) 1.964-2.470 s, plate 2 (right foot) 2.383-2.968 s.
    for side, (on, off) in (("right", (2.383, 2.968)), ("left", (1.964, 2.470))):
        r = results[side]
        t0 = r.provenance["time_zero_s"]
        assert t0 == pytest.approx(on, abs=0.01)
        assert t0 + r.events.toe_offs[0] == pytest.approx(off, abs=0.01)
        stance = r.grf[:, 2] > 20
        ankle = r.clinical_moments()["ankle_dorsiflexion_moment"][stance] / 72.0
        assert -2.0 < ankle.min() < -0.9
        assert np.abs(r.tau[:, :3]).max() < 1e-6


def test_clinical_signs():
    q = np.array([0.0, 0.0, 0.0, 0.2, -0.5])   # shank forward, thigh back: flexed knee
    angles = clinical.clinical_angles(q)
    assert angles["ankle_dorsiflexion"] == pytest.approx(0.2)
    assert angles["knee_flexion"] == pytest.approx(0.5)
    assert angles["hip_flexion"] == pytest.approx(0.3)
