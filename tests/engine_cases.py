"""Compact answers of the shipped simulation problems, for the engine's known-answer test.

Each case runs one problem file of ``problems/`` through the library (no plots, no
files) and returns a flat dict of small arrays: states at a few output times, the status
and the time to fall. ``tests/data/make_engine_reference.py`` stored these answers
before the forward engines were merged (``tests/data/engine_reference.npz``);
``tests/test_engine_reference.py`` checks that the current engine still gives them.
Long runs are cut by ``--set`` style overrides (same problem, shorter window) so the
test stays short; the generator and the test use the same overrides. gait7 runs with
fixed-step RK4 (h = 0.2 ms, as its problem file suggests) instead of the adaptive LSODA:
an adaptive step sequence follows rounding-level changes of the right-hand side (the
merged engine's LSODA run differs by 2e-8, inside LSODA's own tolerance), so only a
fixed-step run is a known answer to 1e-9.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"

#: Problem file -> overrides (shorter windows; everything else as shipped).
CASES = {
    "rod": ("rod.toml", ()),
    "collapse": ("collapse.toml", ()),
    "resynthesis": ("resynthesis.toml", ("simulation.duration=0.6",
                                         "stability.times=[0.05, 0.2, 0.4]")),
    "gait7": ("gait7_contact.toml", ("trial.duration=0.3", "integrator.method=rk4",
                                     "integrator.step=2e-4")),
    "fullbody": ("fullbody_resynthesis.toml", ("simulation.duration=0.15",)),
}
STATUS = {"completed": 0.0, "event": 1.0, "fall": 1.0, "fell": 1.0, "diverged": 2.0}


def _rows(n: int, count: int = 9) -> np.ndarray:
    """About ``count`` output rows spread over n, the last one included."""
    return np.unique(np.linspace(0, n - 1, count).round().astype(int))


def _sim_answers(prefix: str, sim) -> dict[str, np.ndarray]:
    rows = _rows(len(sim.t))
    out = {f"{prefix}/t": sim.t[rows], f"{prefix}/q": sim.q[rows], f"{prefix}/qd": sim.v[rows],
           f"{prefix}/status": np.array([STATUS[_status(sim.status)]]),
           f"{prefix}/fall": np.array([np.nan if sim.time_to_fall is None
                                       else sim.time_to_fall])}
    if sim.grf is not None:
        out[f"{prefix}/grf"] = sim.grf[rows]
    return out


def _status(status) -> str:
    return getattr(status, "value", status)


def _spec(name: str):
    from predgait.workflows.simulate import parse_spec

    file, overrides = CASES[name]
    return parse_spec(PROBLEMS / file, overrides)


def rod_answers() -> dict[str, np.ndarray]:
    """Both force frames of problems/rod.toml."""
    from predgait.dynamics.forward import simulate_rod
    from predgait.models.loading import load_model
    from predgait.simulations.rod import synthetic_rod_trial

    spec = _spec("rod")
    model = load_model("rod")
    trial = synthetic_rod_trial(model, duration=spec.duration, rate=spec.rate, noise=spec.noise)
    x0 = np.concatenate([trial.q[0], trial.v[0]])
    out = {}
    for frame in spec.frames:
        sim = simulate_rod(model, trial.forces(frame), (trial.time[0], trial.time[-1]), x0,
                           frame=frame, options=spec.integrator, t_eval=trial.time)
        out |= _sim_answers(f"rod/{frame.value}", sim)
    return out


def _leg_run(*args, **kwargs):
    from predgait.dynamics.forward import simulate_leg
    from predgait.errors import SimulationDiverged

    try:
        return simulate_leg(*args, **kwargs)
    except SimulationDiverged as exc:
        return exc.partial


def _variant_options(base, variant):
    changes = {k: v for k, v in (("step", variant.step), ("iterations", variant.iterations))
               if v is not None}
    return replace(base, **changes)


def collapse_answers() -> dict[str, np.ndarray]:
    """problems/collapse.toml: the main run and each compared integrator setting."""
    from predgait.dynamics.drivers import LegDrivers
    from predgait.models.loading import load_model

    spec = _spec("collapse")
    model = load_model("leg")
    foot, shank, thigh = np.radians([spec.foot_deg, spec.shank_deg, spec.thigh_deg])
    x0 = np.array([shank - foot, thigh - shank, 0.0, 0.0])
    drivers = LegDrivers.still(base=(0.0, 0.0, foot))
    out = {}
    for i, v in enumerate([None, *spec.compare]):
        opts = spec.integrator if v is None else _variant_options(spec.integrator, v)
        passive = spec.passive if v is None or v.passive is None else v.passive
        sim = _leg_run(model, drivers.with_passive(passive), (0.0, spec.duration), x0,
                       options=opts, fall=spec.fall)
        out |= _sim_answers(f"collapse/{i}", sim)
    return out


def resynthesis_answers() -> dict[str, np.ndarray]:
    """problems/resynthesis.toml (bundled subject01, right leg): main run and variants."""
    from predgait.dynamics.drivers import LegDrivers
    from predgait.dynamics.inverse_trial import bundled_inverse

    spec = _spec("resynthesis")
    inv = bundled_inverse(spec.side)
    t0, t1 = spec.start, spec.start + spec.duration
    out = {}
    for i, v in enumerate([None, *spec.variants]):
        passive = spec.passive if v is None or v.passive is None else v.passive
        opts = spec.integrator if v is None else _variant_options(spec.integrator, v)
        active = LegDrivers.from_inverse(inv, passive=passive)
        sim = _leg_run(inv.model, active, (t0, t1), None, options=opts, fall=spec.fall)
        out |= _sim_answers(f"resynthesis/{i}", sim)
    return out


def gait7_answers() -> dict[str, np.ndarray]:
    """problems/gait7_contact.toml: the kinematic run and the main knee-driven run."""
    from predgait.dynamics.gait7_motion import bundled_gait7_motion, gait7_model
    from predgait.simulations.gait7_sim import kinematic_run, knee_run

    spec = _spec("gait7")
    model = gait7_model(spec.mass, spec.height)
    motion = bundled_gait7_motion(model)
    t = motion.plate_time
    t = t[(t >= spec.start) & (t <= spec.start + spec.duration)]
    kin = kinematic_run(model, motion, spec.contact.law, ground_z=spec.ground_z,
                        t_span=(float(t[0]), float(t[-1])), options=spec.integrator, t_eval=t)
    knee = knee_run(model, motion, kin, spec.contact.law, ground_z=spec.ground_z,
                    sides=spec.knee.sides, source=spec.knee.moment, passive=spec.passive,
                    fall=spec.fall, options=spec.integrator, t_eval=t)
    out = {}
    for name, res in (("kinematic", kin), ("knee", knee)):
        rows = _rows(len(res.run.t))
        out |= {f"gait7/{name}/t": res.run.t[rows], f"gait7/{name}/q": res.run.q[rows],
                f"gait7/{name}/v": res.run.v[rows], f"gait7/{name}/forces": res.forces[rows],
                f"gait7/{name}/status": np.array([STATUS[_status(res.status)]]),
                f"gait7/{name}/fall": np.array([np.nan if res.time_to_fall is None
                                                else res.time_to_fall])}
    return out


def fullbody_answers() -> dict[str, np.ndarray]:
    """problems/fullbody_resynthesis.toml: every variant over a short window.

    Every variant at the [integrator] step (RK4, 1 ms), as stored: the per-variant
    ``step`` (0.1 ms for the free body on contacts, tests/test_fullbody_convergence.py)
    is not applied, so the stored pre-merge answers stay an engine check.
    """
    from predgait.simulations.forward3d import FullbodyDrive, simulate_fullbody
    from predgait.workflows.forward3d_run import inverse_for

    spec = _spec("fullbody")
    drive = FullbodyDrive.from_inverse(inverse_for(spec.trial))
    t0 = spec.start if spec.start is not None else next(iter(drive.heel_strikes),
                                                         float(drive.time[0]))
    out = {}
    for i, mode in enumerate(spec.variants):
        run = simulate_fullbody(drive, mode, (t0, t0 + spec.duration), options=spec.integrator,
                                fall=spec.fall, contact=spec.contact)
        rows = _rows(len(run.t))
        out |= {f"fullbody/{i}/t": run.t[rows], f"fullbody/{i}/q": run.q[rows],
                f"fullbody/{i}/status": np.array([STATUS[_status(run.status)]]),
                f"fullbody/{i}/fall": np.array([np.nan if run.time_to_fall is None
                                                else run.time_to_fall])}
    return out


ANSWERS = {"rod": rod_answers, "collapse": collapse_answers,
           "resynthesis": resynthesis_answers, "gait7": gait7_answers,
           "fullbody": fullbody_answers}
