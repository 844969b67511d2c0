"""Known answer through the CLI: a leg moved by Pinocchio ABA under known torques.

A leg with a lab-style segment table (foot COM at the ankle joint centre) is driven by
known ankle and knee torques, a known hip load and a known ground reaction (stance
0.6..1.6 s); its motion comes from integrating ``pin.aba`` (RK4, 1 kHz), not from the
inverse dynamics under test. Markers (TRC, OpenSim Y-up, mm) and plates (MOT) are
written at 1 kHz and run through ``predgait inverse`` with filtering off: the moments
must equal the applied ones (within 1 N m RMS in stance and in swing; measured 0.01 N m
or less).
"""

import json
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

from predgait.data.frames import OPENSIM_TO_LAB
from predgait.dynamics.external import Load, joint_forces
from predgait.dynamics.inverse import LoadHistory, leg_inverse_dynamics
from predgait.kinematics import clinical
from predgait.models.loading import generate_urdf, model_from_urdf
from test_inverse_synthetic import (
    STANCE,
    frame_positions,
    ground_reaction,
    leg_motion,
    write_grf_mot,
)

RATE = 1000.0


def write_trc(path, time, positions):
    """Lab-frame marker positions (n, 3) m -> an OpenSim TRC (Y-up, mm)."""
    names = list(positions)
    n = time.size
    to_file = OPENSIM_TO_LAB.T
    lines = [f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
             "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\t"
             "OrigDataStartFrame\tOrigNumFrames",
             f"{RATE:g}\t{RATE:g}\t{n}\t{len(names)}\tmm\t{RATE:g}\t1\t{n}",
             "Frame#\tTime\t" + "\t\t\t".join(names),
             "\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, len(names) + 1)), ""]
    xyz = np.concatenate([1000.0 * positions[m] @ to_file.T for m in names], axis=1)
    lines += [f"{k + 1}\t{time[k]:.6f}\t" + "\t".join(f"{v:.9f}" for v in row)
              for k, row in enumerate(xyz)]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def aba_trial(tmp_path_factory):
    """Files of the ABA-generated trial; times (n,) and the applied clinical moments."""
    tmp_path = tmp_path_factory.mktemp("aba_trial")
    table = tmp_path / "segments.csv"     # a lab's table: Dempster-like, foot COM at the ankle
    table.write_text("segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2,"
                     "gyration_fraction,foot_com,com_x_m,com_z_m\n"
                     "foot,1.05,0.27,,0.0045,,offset,0,0\n"
                     "shank,3.38,0.43,0.433,,0.302,,,\n"
                     "thigh,7.26,0.44,0.433,,0.323,,,\n")
    model = model_from_urdf(generate_urdf("leg", segments=table), source=str(table))
    foot = model.pin_model.inertias[model.pin_model.frames[model.frame_id("foot")].parentJoint]
    assert np.allclose(foot.lever, 0.0)
    (tmp_path / "leg.urdf").write_text(model.urdf)
    pm, data = model.pin_model, model.pin_model.createData()

    h = 1 / RATE
    t = np.arange(0.0, 2.4 + 1e-9, h)
    # Feed-forward on the half-step grid of RK4: the shaping trajectory's loads.
    half = np.arange(2 * t.size + 1) * (h / 2)
    q_ref, qd_ref, qdd_ref = leg_motion(half)
    feet = frame_positions(model, q_ref)
    grf = ground_reaction(half, feet["heel"], feet["toe"])
    ground = [LoadHistory("foot", *grf)]
    ref = leg_inverse_dynamics(model, q_ref, qd_ref, qdd_ref, ground)   # shapes the drive

    def drive(j, q, v):
        """Applied joint torques (nv,), hip force, moment and point at half step j.

        ``leg_motion`` gives a feed-forward; PD feedback toward it keeps the integrated
        leg near it (the foot alone would spin about the ankle), acting on every
        coordinate: on the base rows through the hip load, on the joints through the
        torques. The leg's motion is what ABA makes of all these.
        """
        feedback = 100.0 * (q_ref[j] - q) + 2.0 * (qd_ref[j] - v)
        pin.computeJointJacobians(pm, data, q)
        pin.updateFramePlacements(pm, data)
        jac = pin.getFrameJacobian(pm, data, model.frame_id("hip_center"),
                                   pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[[0, 2, 4]]
        wrench = np.linalg.solve(jac[:, :3].T, feedback[:3])   # (Fx, Fz, My) at the hip
        tau = np.zeros(pm.nv)
        tau[3:] = ref.tau[j, 3:] + feedback[3:] - jac[:, 3:].T @ wrench
        hip_f = ref.hip_force[j] + [wrench[0], 0.0, wrench[1]]
        hip_m = ref.hip_moment[j] + [0.0, wrench[2], 0.0]
        hip = data.oMf[model.frame_id("hip_center")].translation.copy()
        return tau, hip_f, hip_m, hip

    def acceleration(j, q, v):
        tau, hip_f, hip_m, hip = drive(j, q, v)
        loads = [Load("foot", grf[0][j], point=grf[1][j], moment=grf[2][j]),
                 Load("hip_center", hip_f, point=hip, moment=hip_m)]
        return pin.aba(pm, data, q, v, tau, joint_forces(model, data, loads))

    q, v = q_ref[0].copy(), qd_ref[0].copy()
    qs = np.empty((t.size, pm.nq))
    names = ("hip_flexion_moment", "knee_flexion_moment", "ankle_dorsiflexion_moment")
    applied = np.empty((t.size, 3))
    for k in range(t.size):
        qs[k] = q
        j = 2 * k
        tau, _, hip_m, _ = drive(j, q, v)
        moments = clinical.clinical_moments(tau[None], np.array([hip_m[1]]))
        applied[k] = [moments[name][0] for name in names]
        k1q, k1v = v, acceleration(j, q, v)
        k2q, k2v = v + h / 2 * k1v, acceleration(j + 1, q + h / 2 * k1q, v + h / 2 * k1v)
        k3q, k3v = v + h / 2 * k2v, acceleration(j + 1, q + h / 2 * k2q, v + h / 2 * k2v)
        k4q, k4v = v + h * k3v, acceleration(j + 2, q + h * k3q, v + h * k3v)
        q = q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    # The ABA motion follows the shaping trajectory closely, but it is its own.
    assert 1e-9 < np.abs(qs - leg_motion(t)[0]).max() < 0.05
    feet = frame_positions(model, leg_motion(t)[0])
    write_trc(tmp_path / "markers.trc", t, frame_positions(model, qs))
    write_grf_mot(tmp_path / "grf.mot", t, [ground_reaction(t, feet["heel"], feet["toe"])])
    # (the ground reaction acts where the shaping trajectory puts the foot: any load
    # anywhere is a known load; the inverse dynamics must take it as it is)
    return tmp_path, t, qs, dict(zip(names, applied.T, strict=True))


def run_cli(folder, out, *extra):
    return subprocess.run(
        [sys.executable, "-m", "predgait", "inverse", str(folder / "markers.trc"),
         "--grf", str(folder / "grf.mot"), "--mass", "72.6", "--markers",
         "hip=hip_center,knee=knee_center,ankle=ankle_center,heel=heel,toe=toe",
         "--cutoff", "0", "--grf-cutoff", "0", "--threshold", "0.5", "--out", str(out),
         *extra], capture_output=True, text=True)


def read_outputs(out):
    summary = json.loads((out / "summary.json").read_text())
    table = np.genfromtxt(out / "inverse_dynamics.csv", delimiter=",", names=True,
                          skip_header=2, comments=None)
    return summary, table


def test_cli_recovers_the_torques_that_moved_the_leg(aba_trial, tmp_path):
    folder, t, _, applied = aba_trial
    run = run_cli(folder, tmp_path / "out", "--model", str(folder / "leg.urdf"))
    assert run.returncode == 0, run.stderr
    summary, table = read_outputs(tmp_path / "out")
    # (the synthetic motion is no walk: its hip moment, 2.6 N m/kg, is a plausibility warning)
    assert summary["status"] in ("completed", "completed with warnings")
    assert summary["flagged_frames"] == 0
    lab_time = table["time"] + summary["provenance"]["time_zero_s"]
    np.testing.assert_allclose(lab_time, t, atol=1e-6)
    inner = np.zeros(t.size, dtype=bool)
    inner[5:-5] = True
    stance = inner & (t > STANCE[0]) & (t < STANCE[1])
    swing = inner & ~((t >= STANCE[0]) & (t <= STANCE[1]))
    for name, value in applied.items():
        error = table[name] - value
        assert np.abs(value[stance]).max() > 5
        for phase in (stance, swing):
            rms = np.sqrt(np.mean(error[phase] ** 2))
            assert rms < 1.0, (name, rms)


def test_swing_beyond_the_knee_range_is_flagged(aba_trial, tmp_path):
    """The same trial on a leg whose knee flexes at most 40 deg (swing reaches 52): those
    frames are flagged and NaN, the run says so and completes (a run where most frames
    are flagged exits 3: test_inverse_options.py)."""
    folder, t, qs, _ = aba_trial
    max_flexion_deg = 40.0
    urdf = (folder / "leg.urdf").read_text()
    narrow = urdf.replace('lower="-2.62"', f'lower="{-np.radians(max_flexion_deg):.6f}"')
    assert narrow != urdf
    (tmp_path / "narrow.urdf").write_text(narrow)
    run = run_cli(folder, tmp_path / "out", "--model", str(tmp_path / "narrow.urdf"))
    assert run.returncode == 0, run.stderr
    summary, table = read_outputs(tmp_path / "out")
    beyond = np.degrees(-qs[:, 4]) > max_flexion_deg
    assert summary["flagged_frames"] == beyond.sum()
    # (plus "and warnings": the synthetic hip moment is beyond walking's)
    assert summary["status"].startswith(f"completed with {beyond.sum()} flagged frames")
    assert summary["status"] in run.stdout
    assert summary["flagged_frames_at_joint_limits"] == {"knee": int(beyond.sum())}
    for name in ("hip_flexion_moment", "knee_flexion_moment", "ankle_dorsiflexion_moment"):
        assert np.isnan(table[name][beyond]).all()
        assert np.isfinite(table[name][~flagged_near(beyond)]).all()
    kinematics = np.genfromtxt(tmp_path / "out" / "kinematics.csv", delimiter=",", names=True,
                               skip_header=2, comments=None)
    assert np.isnan(kinematics["knee_flexion"][beyond]).all()
    assert 100 < beyond.sum() < 0.5 * t.size
    assert "error" not in run.stderr


def flagged_near(flags, reach=2):
    """Frames within ``reach`` of a flagged frame (their derivatives use it)."""
    out = flags.copy()
    for shift in range(1, reach + 1):
        out[shift:] |= flags[:-shift]
        out[:-shift] |= flags[shift:]
    return out
