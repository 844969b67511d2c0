"""Whole-body (35 DOF) speed: 3D inverse dynamics of 1000 frames, IK per frame, 1 s of
forward dynamics (also driven by subject01's inverse dynamics); ratio against OpenSim
4.6's InverseDynamicsTool.

OpenSim runs when OPENSIM_PYTHON (a Python with `pip install opensim`; its wheel bundles
a CasADi that clashes with ours, hence another process) and GAIT2354_DIR are set (see
opensim_subject01.py); otherwise the ratio uses the quoted figure, about 140 ms for the 73
frames of the example trial with its 23-DOF model (~1.9 ms a frame).
Run: .venv/bin/python benchmarks/bench_fullbody.py
"""

import json
import os
import subprocess
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from predgait.models.fullbody import MARKERS
from predgait.models.loading3d import load_fullbody

OPENSIM_ID_MS_PER_FRAME = 140.0 / 73
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
    per = t_id / n * 1e3
    print(f"3D inverse dynamics, {n} frames of the 35-DOF body (pin.rnea loop): "
          f"{t_id * 1e3:.2f} ms ({per * 1e3:.1f} us/frame; target < 20 ms)")
    print(f"  vs OpenSim 4.6 InverseDynamicsTool (quoted ~{OPENSIM_ID_MS_PER_FRAME:.2f} ms/frame,"
          f" not run here): {OPENSIM_ID_MS_PER_FRAME / per:.0f}x faster per frame")

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

    if DATA.is_dir():
        pipeline()


def opensim_tools() -> dict | None:
    """OpenSim's IK and ID tools on the same trial, in their own process (see
    opensim_subject01.py); None with a note when OPENSIM_PYTHON / GAIT2354_DIR are not set."""
    python, folder = os.environ.get("OPENSIM_PYTHON"), os.environ.get("GAIT2354_DIR")
    if not (python and folder):
        print("OpenSim tools: not run (set OPENSIM_PYTHON to a Python with `pip install "
              "opensim` and GAIT2354_DIR to opensim-models' Pipelines/Gait2354_Simbody files "
              "with OutputReference/subject01_simbody.osim beside them)")
        return None
    child = subprocess.run([python, str(Path(__file__).with_name("opensim_subject01.py")),
                            folder], capture_output=True, text=True)
    if child.returncode != 0:
        print(f"OpenSim tools: failed ({(child.stderr.strip().splitlines() or ['?'])[-1]})")
        return None
    return json.loads(child.stdout.strip().splitlines()[-1])


def pipeline():
    """Whole `predgait inverse --model fullbody` work in-process (read, static calibration,
    IK, filter, ID, files), on all 151 frames and on OpenSim's window 0.4-1.6 s (73 frames)."""
    import tempfile

    from predgait.dynamics.inverse3d import inverse_dynamics_3d
    from predgait.workflows.inverse3d import (
        inverse_fullbody,
        read_marker_map,
        read_trial,
        run_inverse_fullbody,
    )

    repo = Path(__file__).resolve().parents[1]
    files = [DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"]
    mmap = repo / "problems" / "markers_fullbody_subject01.toml"
    static = DATA / "subject01_static.trc"
    rows = {}
    for label, window in (("all 151 frames", None), ("0.4-1.6 s, 73 frames", (0.4, 1.6))):
        with tempfile.TemporaryDirectory() as tmp:
            run = lambda w=window, t=tmp: run_inverse_fullbody(  # noqa: E731
                files, mmap, mass=72.6, height=1.8034, out_dir=Path(t) / "o", static=static,
                window=w, force=True)
            whole = best(run, 3)
        markers, plates = read_trial(files)
        from predgait.data import read_trc
        result = inverse_fullbody(markers, plates, read_marker_map(mmap), mass=72.6,
                                  height=1.8034, static=read_trc(static), window=window)
        id_only = best(lambda r=result: inverse_dynamics_3d(r.model, r.q, r.v, r.a, r.plates,
                                                            r.sides), 5)
        rows[label] = (whole, id_only, result.q.shape[0])
        print(f"predgait whole run, {label}: {whole * 1e3:.0f} ms "
              f"({whole / result.q.shape[0] * 1e3:.2f} ms/frame); ID alone {id_only * 1e3:.1f} ms")
    whole, id_only, n = rows["0.4-1.6 s, 73 frames"]
    tools = opensim_tools()
    if tools is None:
        print(f"  vs OpenSim ID (quoted ~140 ms for these 73 frames): whole run "
              f"{0.140 / whole:.2f}x, ID alone {0.140 / id_only:.0f}x (target: whole run >= 10x)")
        return
    print(f"OpenSim {tools['version']} tools on the same window, Gait2354 (23 DOF): "
          f"IK {tools['ik_s'] * 1e3:.0f} ms, ID {tools['id_s'] * 1e3:.0f} ms")
    both = tools["ik_s"] + tools["id_s"]
    print(f"  ratios: predgait whole run vs OpenSim IK+ID {both / whole:.1f}x;"
          f" vs OpenSim ID alone {tools['id_s'] / whole:.2f}x (target >= 10x);"
          f" ID alone vs ID tool {tools['id_s'] / id_only:.0f}x")


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
    main()
    driven_forward()
