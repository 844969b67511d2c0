"""Whole-body (35 DOF) speed: `predgait inverse --model fullbody` against OpenSim's IK and ID
tools, 3D inverse dynamics of 1000 frames, IK per frame, forward dynamics.

OpenSim (the peer) runs in its own process when OPENSIM_PYTHON (a Python with
`pip install opensim`; its wheel bundles a CasADi that clashes with ours) and GAIT2354_DIR
(opensim-models' Pipelines/Gait2354_Simbody files, see opensim_subject01.py) are set;
otherwise the OpenSim rows print "peer not available".

Run: python benchmarks/bench_fullbody.py [--repeat N]
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
from timing import (
    REPO,
    Row,
    Timing,
    gait2354_folder,
    opensim_python,
    print_rows,
    run_peer,
    time_call,
    time_process,
)

from predgait.models.fullbody import MARKERS
from predgait.models.loading3d import load_fullbody

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"


def best(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    model = load_fullbody()
    pm, data = model.pin_model, model.pin_model.createData()
    rng = np.random.default_rng(0)
    n = 1000
    q = np.array([pin.randomConfiguration(pm, -np.ones(pm.nq), np.ones(pm.nq))
                  for _ in range(n)])
    v, a = rng.normal(size=(n, pm.nv)), rng.normal(size=(n, pm.nv))
    tau = np.empty((n, pm.nv))

    def rnea_loop():
        for k in range(n):
            tau[k] = pin.rnea(pm, data, q[k], v[k], a[k])

    t_id = best(rnea_loop)
    print(f"3D inverse dynamics, {n} frames of the 35-DOF body (pin.rnea loop): "
          f"{t_id * 1e3:.2f} ms ({t_id / n * 1e6:.1f} us/frame; target < 20 ms); OpenSim: "
          "peer not available (no same-work peer for random frames)")

    from predgait.kinematics.ik3d import solve_ik
    ids = [model.frame_id(f) for f in MARKERS]
    base = model.neutral()
    frames = 100
    xyz = np.empty((frames, len(ids), 3))
    qs = np.tile(base, (frames, 1))
    qs[:, 7:] = 0.3 * np.sin(np.linspace(0, 3, frames))[:, None] * rng.uniform(-1, 1, 29)
    qs[:, 7:] = np.clip(qs[:, 7:], pm.lowerPositionLimit[7:], pm.upperPositionLimit[7:])
    for k in range(frames):
        pin.framesForwardKinematics(pm, data, qs[k])
        xyz[k] = [data.oMf[i].translation for i in ids]
    xyz += rng.normal(0, 0.002, xyz.shape)
    t_ik = best(lambda: solve_ik(model, np.arange(frames) / 100, xyz, MARKERS), 2)
    print(f"3D IK, {len(ids)} markers: {t_ik / frames * 1e3:.2f} ms/frame")

    def forward():  # 1 s, semi-implicit Euler at 1 kHz, gravity-compensated PD hold
        x, dx = base.copy(), np.zeros(pm.nv)
        hold = pin.rnea(pm, data, base, np.zeros(pm.nv), np.zeros(pm.nv))
        for _ in range(1000):
            torque = np.zeros(pm.nv)
            torque[6:] = hold[6:] - 200.0 * pin.difference(pm, base, x)[6:] - 20.0 * dx[6:]
            dx = dx + 1e-3 * pin.aba(pm, data, x, dx, torque)
            x = pin.integrate(pm, x, 1e-3 * dx)

    t_fd = best(forward, 3)
    print(f"Forward dynamics, 1 s at 1 kHz (ABA, 35 DOF): {t_fd * 1e3:.1f} ms "
          f"({1.0 / t_fd:.0f}x real time)")



FULLBODY_ARGS = ("--mass", "72.6", "--height", "1.8034", "--model", "fullbody",
                 "--marker-map", str(REPO / "problems" / "markers_fullbody_subject01.toml"))


def rows(repeat: int) -> list[Row]:
    """`predgait inverse --model fullbody` and OpenSim's tools: whole processes and in
    process (for run_all.py)."""
    if not DATA.is_dir():
        print(f"full body: {DATA} not found; rows not run")
        return []
    files = [str(DATA / "subject01_walk1.trc"), "--grf", str(DATA / "subject01_walk1_grf.mot"),
             "--static", str(DATA / "subject01_static.trc")]
    command = [sys.executable, "-m", "predgait", "inverse", *files, *FULLBODY_ARGS, "--force"]
    with tempfile.TemporaryDirectory() as tmp:
        ours = time_process([*command, "--out", f"{tmp}/out"], repeat)
        bare = time_process([*command, "--out", f"{tmp}/bare", "--no-plots"], repeat)
    does = ("read TRC+MOT+static, scaling and calibration, 3D IK and ID of the 35-DOF body on "
            "all 151 frames, tables and plots")
    folder, python = gait2354_folder(), opensim_python()
    script = str(Path(__file__).with_name("opensim_subject01.py"))
    whole = {}
    for tools in ("id", "ik,id"):
        whole[tools] = (time_process([python, script, folder, "--tools", tools, "--repeat",
                                      "1"], repeat) if folder and python else None)
    out = [Row("predgait inverse --model fullbody vs OpenSim ID tool alone, whole processes "
               "(goal: >= 10x)", ours, does, whole["id"],
               "Python + import opensim + ID tool on the shipped IK motion (23 DOF, 73 frames)",
               unit="s"),
           Row("predgait inverse --model fullbody --no-plots vs OpenSim ID tool alone, whole "
               "processes (goal: >= 10x)", bare, does.replace("tables and plots", "tables"),
               whole["id"],
               "Python + import opensim + ID tool on the shipped IK motion (23 DOF, 73 frames)",
               unit="s"),
           Row("predgait inverse --model fullbody vs OpenSim IK + ID tools, whole processes",
               ours, does, whole["ik,id"],
               "Python + import opensim + IK tool + ID tool (23 DOF, 76 frames)", unit="s")]
    ours_in, peer_in = in_process(repeat, folder)
    out.append(Row("full body IK + ID in process, subject01 0.4-1.6 s", ours_in,
                   "run_inverse_fullbody: read, calibrate, IK, filter, ID, tables, no plots "
                   "(73 frames, 35 DOF)", peer_in, "IK tool + ID tool runs after import, "
                   "model loading included (76 frames, 23 DOF)", unit="s"))
    return out


def in_process(repeat: int, folder: str | None) -> tuple[Timing, Timing | None]:
    """predgait's whole full-body run in this process, and OpenSim's IK + ID tool runs."""
    from predgait.report.figures import plots_off
    from predgait.workflows.inverse3d import run_inverse_fullbody

    files = [DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"]
    marker_map = REPO / "problems" / "markers_fullbody_subject01.toml"
    with tempfile.TemporaryDirectory() as tmp, plots_off():
        ours = time_call(lambda: run_inverse_fullbody(
            files, marker_map, mass=72.6, height=1.8034, out_dir=Path(tmp) / "o",
            static=DATA / "subject01_static.trc", window=(0.4, 1.6), force=True), repeat)
    peer = None
    if folder:
        result = run_peer("opensim_subject01.py", folder, "--repeat", str(repeat))
        if "error" not in result:
            peer = Timing(tuple(a + b for a, b in zip(result["ik"]["wall"],
                                                       result["id"]["wall"], strict=True)),
                          tuple(a + b for a, b in zip(result["ik"]["cpu"],
                                                       result["id"]["cpu"], strict=True)))
        else:
            print(f"OpenSim tools in process: {result['error']}")
    return ours, peer


def driven_forward():
    """1 s of the full body driven by subject01's 3D inverse dynamics, RK4 1 ms.

    Pelvis prescribed (29 free joints) and free (35). The moment-driven body falls within
    about 0.05 s (stance-foot instability, see tests/test_forward3d.py), so the 1 s cost
    is timed on the 4000 right-hand sides of RK4 along the measured path, then each
    actual run to its fall; the kinematic-joint runs on contact springs last the second.
    """
    from predgait.simulations.forward3d import (
        FullbodyDrive,
        GroundMode,
        JointMode,
        Mode,
        PelvisMode,
        build_system,
        simulate_fullbody,
    )
    from predgait.workflows.forward3d_run import inverse_for
    from predgait.workflows.simulate import parse_spec

    problem = Path(__file__).resolve().parents[1] / "problems" / "fullbody_resynthesis.toml"
    drive = FullbodyDrive.from_inverse(inverse_for(parse_spec(problem).trial))
    t0 = drive.heel_strikes[0]
    for pelvis in (PelvisMode.PRESCRIBED, PelvisMode.FREE):
        mode = Mode(pelvis=pelvis)
        system, history, _ = build_system(drive, mode)
        times = t0 + 0.25e-3 * np.arange(4000)
        states = [system.state(*history(t)[:2]) for t in times]

        def rhs_1s(system=system, times=times, states=states):
            for t, x in zip(times, states, strict=True):
                system(t, x)

        wall = best(rhs_1s, 2)
        start = time.perf_counter()
        run = simulate_fullbody(drive, mode, (t0, t0 + 1.0))
        fall_wall = time.perf_counter() - start
        print(f"Driven full body, moments, measured GRF, pelvis {pelvis.value} "
              f"({system.nvf} free DOF): 1 s RK4 1 ms = {wall * 1e3:.0f} ms "
              f"({1.0 / wall:.2f}x real time); actual run to its fall at "
              f"{run.time_to_fall:.3f} s: {fall_wall * 1e3:.0f} ms")
    for pelvis in (PelvisMode.TRANSLATION, PelvisMode.FREE):
        mode = Mode(pelvis=pelvis, joints=JointMode.KINEMATIC, ground=GroundMode.CONTACT)
        start = time.perf_counter()
        run = simulate_fullbody(drive, mode, (t0, t0 + 1.0))
        wall = time.perf_counter() - start
        simulated = run.t[-1] - t0
        print(f"Kinematic joints on contacts, pelvis {pelvis.value}: {simulated:.3f} s "
              f"simulated ({run.status}) in {wall * 1e3:.0f} ms ({simulated / wall:.2f}x "
              "real time)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    print_rows(rows(parser.parse_args().repeat))
    main()
    driven_forward()
