"""Run a ``simulate`` spec and write its result folder (states, summary, plots, GIF).

Files (in the folder given, normally a staging folder of
:func:`predgait.workflows.output.staged_output`):
``states.sto`` (time, each coordinate in rad/m, then each velocity) or
``states_partial.sto`` when the main run diverged, ``summary.json`` (status, integrator,
time to fall, RMS per coordinate, provenance), PNG plots, ``stick.png`` (figures every
``stick_interval`` s, thesis Fig. 4.2.2) and ``stick.gif``.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.analysis.contributions import contribution_history
from predgait.analysis.deviation import deviation
from predgait.analysis.plausibility import grf_check, record
from predgait.analysis.stability import linearize
from predgait.data.storage import write_storage
from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import LegSystem, SimulationResult, simulate_leg, simulate_rod
from predgait.errors import InputError, SimulationDiverged
from predgait.models.loading import load_model
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary
from predgait.textfile import source_name
from predgait.workflows.simulate import CollapseSpec, ResynthesisSpec, RodSpec, Variant
from predgait.workflows.trials import LegTrial


def _options_dict(o) -> dict:
    return {"method": o.method.value, "step_s": o.step, "iterations": o.iterations,
            "rtol": o.rtol, "atol": o.atol}


def _run(fn, *args, **kwargs) -> tuple[SimulationResult, str | None]:
    """Run a simulation; a divergence returns its partial result and the message."""
    try:
        return fn(*args, **kwargs), None
    except SimulationDiverged as exc:
        return exc.partial, str(exc)


def write_states(folder: Path, sim: SimulationResult, *, name: str = "states",
                 header: dict | None = None) -> Path:
    """``name.sto`` (or ``name_partial.sto``): time, coordinates, then velocities."""
    columns = {n: sim.q[:, i] for i, n in enumerate(sim.coordinate_names)}
    columns |= {f"{n}_speed": sim.v[:, i] for i, n in enumerate(sim.coordinate_names)}
    path = folder / (f"{name}_partial.sto" if sim.partial else f"{name}.sto")
    head = {"units": "m, rad, m/s, rad/s", "status": sim.status,
            "integrator": json.dumps(_options_dict(sim.options)).replace(" ", "")}
    write_storage(path, sim.t, columns, header=head | (header or {}))
    return path


def _save(fig_or_axes, path: Path) -> None:
    from predgait.report.figures import save_figure

    save_figure(np.atleast_1d(fig_or_axes)[0].figure, path)


def _summary(folder: Path, spec, data: dict, checks=()) -> dict:
    """Write summary.json with the plausibility ``checks`` (analysis.plausibility.record)."""
    data = {"kind": type(spec).__name__.replace("Spec", "").lower(), **data,
            "provenance": {"problem": source_name(spec.source), "predgait": __version__}
            | data.get("provenance", {})}
    return write_summary(folder / "summary.json", record(data, checks))


def run_spec(spec, folder: Path, *, progress: bool = False) -> dict:
    """Run a spec into ``folder``; returns the summary (``status`` may be "diverged")."""
    if isinstance(spec, RodSpec):
        return _run_rod(spec, folder, progress)
    if isinstance(spec, CollapseSpec):
        return _run_collapse(spec, folder, progress)
    if isinstance(spec, ResynthesisSpec):
        return _run_resynthesis(spec, folder, progress)
    from predgait.workflows.gait7_spec import Gait7Spec

    if isinstance(spec, Gait7Spec):
        from predgait.workflows.gait7_run import run_gait7

        return run_gait7(spec, folder, progress=progress)
    from predgait.workflows.forward3d_spec import FullbodySpec

    if isinstance(spec, FullbodySpec):
        from predgait.workflows.forward3d_run import run_fullbody

        return run_fullbody(spec, folder, progress=progress)
    raise InputError(f"unknown spec {spec!r}")


# ---------------------------------------------------------------------------- rod
def _run_rod(spec: RodSpec, folder: Path, progress: bool) -> dict:
    from predgait.simulations.rod import synthetic_rod_trial

    model = load_model("rod")
    trial = synthetic_rod_trial(model, duration=spec.duration, rate=spec.rate, noise=spec.noise)
    x0 = np.concatenate([trial.q[0], trial.v[0]])
    span = (float(trial.time[0]), float(trial.time[-1]))

    def rms(sim):
        n = len(sim.t)
        return dict(zip(model.coordinate_names, np.sqrt(np.mean(
            (sim.q - trial.q[:n]) ** 2, axis=0)).tolist(), strict=True))

    runs, messages, table = {}, {}, []
    for frame in spec.frames:
        sim, msg = _run(simulate_rod, model, trial.forces(frame), span, x0, frame=frame,
                        options=spec.integrator, t_eval=trial.time, progress=progress)
        runs[frame.value], messages[frame.value] = sim, msg
        write_states(folder, sim, name=f"states_{frame.value}")
        table.append({"frame": frame.value, "status": sim.status, "rms": rms(sim),
                      "message": msg or sim.message})
    main = runs.get("body") or next(iter(runs.values()))
    write_states(folder, main)
    study = []
    for step in spec.step_study:
        for iterations in sorted({1, spec.integrator.iterations}):
            opts = replace(spec.integrator, step=step, iterations=iterations)
            for frame in spec.frames:
                sim, msg = _run(simulate_rod, model, trial.forces(frame), span, x0,
                                frame=frame, options=opts, t_eval=trial.time)
                study.append({"frame": frame.value, "step_s": step, "iterations": iterations,
                              "status": sim.status, "rms": rms(sim)})
    if plots_wanted():
        _plot_rod(folder, spec, model, trial, runs, main, study)
    diverged = [k for k, m in messages.items() if m]
    return _summary(folder, spec, {
        "status": "diverged" if diverged else "completed",
        "message": "; ".join(messages[k] for k in diverged) or "completed",
        "integrator": _options_dict(spec.integrator), "time_to_fall_s": None,
        "rms": {r["frame"]: r["rms"] for r in table}, "runs": table, "step_study": study,
        "provenance": {"trial": f"synthetic rod, {spec.rate:g} Hz, noise {spec.noise:g}",
                       "model": model.source}})


def _plot_rod(folder: Path, spec: RodSpec, model, trial, runs: dict, main, study) -> None:
    from predgait.report.raster import save_chart
    from predgait.report.simulation_plots import coordinate_panels
    from predgait.report.stick import save_stick_chart
    from predgait.report.viewer import write_motion

    names = model.coordinate_names
    save_chart(folder / "rod_trajectories.png",
               coordinate_panels({k: (s.t, s.q) for k, s in runs.items()}, names,
                                 reference=(trial.time, trial.q), xlabel="trial time (s)"),
               size=(6, 2.2 * len(names)), columns=1, hspace=0.3)
    if study:
        from predgait.report.figures import new_figure

        fig, ax = new_figure(figsize=(5, 4))
        for frame in spec.frames:
            for it in sorted({r["iterations"] for r in study}):
                rows = [r for r in study if r["frame"] == frame.value and r["iterations"] == it]
                ax.loglog([r["step_s"] for r in rows],
                          [np.degrees(r["rms"]["base_pitch"]) for r in rows], "o-",
                          label=f"{frame.value}, {it} iteration(s)")
        ax.set_xlabel("step h (s)")
        ax.set_ylabel("RMS error of theta (deg)")
        ax.legend(fontsize=7)
        _save(ax, folder / "step_study.png")
    save_stick_chart(folder / "stick.png", model, main.t, {"": main.q}, interval=0.1)
    write_motion(folder, model, main.t, main.q, reference_q=trial.q[:len(main.t)])


# ----------------------------------------------------------------------- collapse
def _variant_options(base, variant: Variant):
    changes = {}
    if variant.step is not None:
        changes["step"] = variant.step
    if variant.iterations is not None:
        changes["iterations"] = variant.iterations
    return replace(base, **changes)


def _run_collapse(spec: CollapseSpec, folder: Path, progress: bool) -> dict:
    from predgait.report.raster import save_chart
    from predgait.report.simulation_plots import FROM_START, coordinate_panels
    from predgait.report.stick import save_stick_chart
    from predgait.report.viewer import write_motion

    model = load_model("leg")
    foot, shank, thigh = np.radians([spec.foot_deg, spec.shank_deg, spec.thigh_deg])
    x0 = np.array([shank - foot, thigh - shank, 0.0, 0.0])
    drivers = LegDrivers.still(base=(0.0, 0.0, foot), passive=spec.passive)
    variants = [Variant("main", passive=spec.passive), *spec.compare]
    runs, rows = {}, []
    for v in variants:
        opts = _variant_options(spec.integrator, v)
        passive = v.passive if v.passive is not None else spec.passive
        sim, msg = _run(simulate_leg, model, drivers.with_passive(passive),
                        (0.0, spec.duration), x0, options=opts, fall=spec.fall,
                        progress=progress and v.name == "main")
        runs[v.name] = sim
        rows.append({"name": v.name, **_options_dict(opts), "status": sim.status,
                     "time_to_fall_s": sim.time_to_fall, "end_time_s": float(sim.t[-1]),
                     "final_deg": dict(zip(sim.free, np.degrees(sim.q[-1, 3:]).tolist(),
                                           strict=True)),
                     "message": msg or sim.message})
    main = runs["main"]
    write_states(folder, main)
    lin = linearize(LegSystem(model, drivers), 0.0, x0)
    if plots_wanted():
        save_chart(folder / "angles.png",
                   coordinate_panels({k: (s.t, s.q[:, 3:]) for k, s in runs.items()},
                                     ("ankle", "knee"), kind="leg", xlabel=FROM_START),
                   size=(6, 4.4), columns=1, hspace=0.3)
        longest = max(runs.values(), key=lambda s: len(s.t))
        save_stick_chart(folder / "stick.png", model, longest.t,
                         {name: sim.q for name, sim in runs.items()},
                         interval=spec.stick_interval)
        write_motion(folder, model, main.t, main.q)
    return _summary(folder, spec, {
        "status": "diverged" if main.partial else main.status, "message": rows[0]["message"],
        "integrator": _options_dict(spec.integrator),
        "n_rhs_evaluations": main.n_rhs_evaluations, "time_to_fall_s": main.time_to_fall,
        "rms": None, "runs": rows,
        "stability_at_start": _eig(lin),
        "provenance": {"model": model.source, "initial_deg": {
            "foot": spec.foot_deg, "shank": spec.shank_deg, "thigh": spec.thigh_deg}}})


def _eig(lin) -> dict:
    return {"eigenvalues_real": lin.eigenvalues.real.tolist(),
            "eigenvalues_imag": lin.eigenvalues.imag.tolist(),
            "unstable": int(lin.unstable.size), "e_folding_time_s": lin.e_folding_time}


# -------------------------------------------------------------------- resynthesis
def _run_resynthesis(spec: ResynthesisSpec, folder: Path, progress: bool) -> dict:
    from predgait.report.raster import save_chart
    from predgait.report.simulation_plots import (
        contribution_panels,
        coordinate_panels,
        deviation_panel,
        grf_panels,
    )
    from predgait.report.stick import save_stick_chart
    from predgait.report.viewer import write_motion

    inv = (spec.trial or LegTrial(spec.side, spec.inverse_problem)).inverse()
    model = inv.model
    drivers = LegDrivers.from_inverse(inv)
    t0 = spec.start
    if spec.duration is not None:
        t1 = t0 + spec.duration
    else:
        cycle = inv.first_cycle()
        t1 = cycle[1] if cycle and cycle[0] <= t0 < cycle[1] else float(inv.time[-1])
    if not (inv.time[0] <= t0 < t1 <= inv.time[-1] + 1e-9):
        raise InputError(f"{spec.source}: simulation {t0:g}..{t1:g} s is outside the trial "
                         f"{inv.time[0]:.3f}..{inv.time[-1]:.3f} s (time 0 = heel strike).")
    late = [t for t in spec.stability_times if t0 + t > t1]
    if late:
        raise InputError(f"{spec.source}: [stability] times {late} s are after the end of the "
                         f"run ({t1 - t0:.3f} s after its start); give times within the run.")
    variants = [Variant("main", passive=spec.passive), *spec.variants]
    runs, rows, main_msg = {}, [], None
    for v in variants:
        passive = v.passive if v.passive is not None else spec.passive
        in_thigh = spec.hip_in_thigh_frame if v.hip_in_thigh_frame is None \
            else v.hip_in_thigh_frame
        active = replace(LegDrivers.from_inverse(inv, passive=passive),
                         hip_in_thigh_frame=in_thigh)
        sim, msg = _run(simulate_leg, model, active, (t0, t1), None,
                        options=_variant_options(spec.integrator, v), fall=spec.fall,
                        progress=progress and v.name == "main")
        runs[v.name] = sim
        main_msg = msg if v.name == "main" else main_msg
        dev = deviation(sim, inv.time, inv.q, threshold_deg=spec.threshold_deg)
        rows.append({"name": v.name, "status": sim.status, "time_to_fall_s": sim.time_to_fall,
                     "hip_force_frame": "thigh" if in_thigh else "lab",
                     "end_time_s": float(sim.t[-1]),
                     "rms_deg": {k: float(np.degrees(x)) for k, x in dev.rms.items()},
                     "time_to_threshold_s": dev.time_to_threshold,
                     "coordinate_at_threshold": dev.coordinate_at_threshold,
                     "max_knee_hyperextension_deg": float(max(0.0, np.degrees(
                         np.max(sim.q[:, 4])))),
                     "message": msg or sim.message})
    main = runs["main"]
    write_states(folder, main, header={"trial": inv.provenance.get("trial", "")})
    measured_grf = (inv.time, inv.grf, inv.cop)
    inside = (inv.time >= t0) & (inv.time <= main.t[-1])
    grf_i = np.column_stack([np.interp(inv.time[inside], main.t, main.grf[:, i])
                             for i in (0, 2)])
    grf_rms = np.sqrt(np.mean((grf_i - inv.grf[inside][:, [0, 2]]) ** 2, axis=0))
    system = LegSystem(model, replace(LegDrivers.from_inverse(inv, passive=spec.passive),
                                      hip_in_thigh_frame=spec.hip_in_thigh_frame))
    stability = []
    for t in spec.stability_times:
        tt = t0 + t
        if tt <= t1:
            x = np.concatenate([drivers.reference_q(tt)[3:], drivers.reference_qd(tt)[3:]])
            stability.append({"time_s": tt, **_eig(linearize(system, tt, x))})
    parts = contribution_history(system, main)
    ref_q = np.column_stack([np.interp(main.t, inv.time, inv.q[:, i]) for i in range(5)])
    if plots_wanted():
        joints = ("ankle", "knee")
        save_chart(folder / "angles.png",
                   coordinate_panels({k: (s.t, s.q[:, 3:]) for k, s in runs.items()}, joints,
                                     reference=(inv.time[inv.time <= t1],
                                                inv.q[inv.time <= t1, 3:]), kind="leg"),
                   size=(6, 4.4), columns=1, hspace=0.3)
        save_chart(folder / "deviation.png",
                   [deviation_panel(main.t, main.q[:, 3:], (inv.time, inv.q[:, 3:]), joints,
                                    threshold_deg=spec.threshold_deg,
                                    time_to_threshold=rows[0]["time_to_threshold_s"],
                                    time_to_fall=main.time_to_fall)],
                   size=(7, 3.8), title="Deviation from the measured motion")
        save_chart(folder / "grf.png", grf_panels(main.t, main.grf, main.cop,
                                                  measured=measured_grf),
                   size=(6, 7), columns=1, hspace=0.3)
        save_chart(folder / "contributions.png", contribution_panels(main.t, parts, joints,
                                                                      kind="leg"),
                   size=(6, 5.2), columns=1, hspace=0.3)
        save_stick_chart(folder / "stick.png", model, main.t,
                         {"measured": ref_q, "synthesized": main.q},
                         interval=spec.stick_interval)
        measured = [np.column_stack([np.interp(main.t, inv.time, a[:, i]) for i in range(3)])
                    for a in (inv.grf, inv.cop)]
        write_motion(folder, model, main.t, main.q, reference_q=ref_q,
                     grf=(main.grf, main.cop), measured_grf=measured)
    return _summary(folder, spec, {
        "status": "diverged" if main.partial else main.status,
        "message": main_msg or main.message, "integrator": _options_dict(spec.integrator),
        "n_rhs_evaluations": main.n_rhs_evaluations, "time_to_fall_s": main.time_to_fall,
        "time_span_s": [t0, t1], "rms_deg": rows[0]["rms_deg"],
        "time_to_threshold_s": rows[0]["time_to_threshold_s"],
        "threshold_deg": spec.threshold_deg,
        "hip_force_frame": "thigh" if spec.hip_in_thigh_frame else "lab",
        "grf_rms_n": {"x": float(grf_rms[0]), "z": float(grf_rms[1])}, "runs": rows,
        "stability": stability,
        "provenance": {"trial": inv.provenance.get("trial", ""), "model": model.source,
                       "side": inv.side}},
        [grf_check(float(np.nanmax(main.grf[:, 2])) / (inv.body_mass * model.gravity),
                   "peak vertical ground reaction (simulated)")])
