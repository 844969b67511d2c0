"""Run a gait7 spec and write its result folder (thesis 2.4, Fig. 2.4.1).

Files: ``states.sto`` (kinematic run: time, the 9 coordinates m/rad, then velocities),
``motion.mot`` (the kinematic run as OpenSim's 2D gait model's coordinates, deg and m:
:mod:`predgait.kinematics.osim2d_motion`), ``states_knee.sto`` (knee-driven run of the
main settings; ``states_knee_partial.sto`` when it diverged), ``grf.sto`` and ``grf.csv``
(time, simulated vertical GRF per foot and per contact point, measured per foot, N),
``summary.json`` (per run: GRF RMS
difference, correlation and stance peaks, mean total vertical force vs body weight,
HAT height offset and deviation, knee-driven status and time to fall), ``grf.png``
(simulated vs measured vertical GRF per foot and the HAT height), ``knee.png`` (knee
angles of the knee-driven runs), ``stick.png`` and ``stick.gif`` (kinematic run, measured
in grey).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.analysis.plausibility import grf_check, record
from predgait.data.storage import write_csv, write_storage
from predgait.dynamics.gait7_motion import SIDES, bundled_gait7_motion, gait7_model
from predgait.dynamics.integrators import Status
from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint
from predgait.kinematics.osim2d_motion import write_osim2d_motion
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.report.figures import plots_wanted
from predgait.report.tidy import write_summary
from predgait.simulations.gait7_sim import Gait7Result, grf_comparison, kinematic_run, knee_run
from predgait.textfile import source_name
from predgait.workflows.gait7_spec import Gait7Spec, Gait7Variant


def _window(spec: Gait7Spec, motion) -> np.ndarray:
    """Output times: the plate samples inside the simulated window, s."""
    t0, t1 = spec.start, spec.start + spec.duration
    if not (motion.time[0] <= t0 and t1 <= motion.time[-1]):
        raise InputError(f"{spec.source}: trial.start/duration give {t0:g}..{t1:g} s, "
                         f"outside the trial {motion.time[0]:.3f}..{motion.time[-1]:.3f} s.")
    t = motion.plate_time
    return t[(t >= t0) & (t <= t1)]


def _kinematic_metrics(spec, model, motion, t, kin: Gait7Result) -> dict:
    rows = np.searchsorted(motion.plate_time, kin.run.t)
    measured = {s: motion.plate_fz[s][rows] for s in SIDES}
    z = model.coordinate_index("base_z")
    dz = kin.run.q[:, z] - np.interp(kin.run.t, motion.time, motion.q[:, z])
    total = kin.foot_fz("right") + kin.foot_fz("left")
    return {"status": kin.status.value,
            "grf": {s: grf_comparison(kin.run.t, kin.foot_fz(s), measured[s]) for s in SIDES},
            "mean_total_vertical_n": float(np.mean(total)),
            "body_weight_n": float(model.total_mass() * model.gravity),
            "mean_measured_vertical_n": float(np.mean(measured["right"] + measured["left"])),
            "hat_height_offset_m": float(np.mean(dz)),
            "hat_height_deviation_rms_m": float(np.std(dz)),
            "hat_height_deviation_max_m": float(np.max(np.abs(dz - np.mean(dz))))}


def _run_variant(spec: Gait7Spec, v: Gait7Variant, model, motion, t, cache: dict,
                 progress: bool) -> tuple[dict, Gait7Result, Gait7Result | None]:
    contact = v.contact or spec.contact
    knee = v.knee or spec.knee
    passive = v.passive if v.passive is not None else spec.passive
    key = id(contact)
    if key not in cache:
        cache[key] = kinematic_run(model, motion, contact.law, ground_z=spec.ground_z,
                                   t_span=(float(t[0]), float(t[-1])),
                                   options=spec.integrator, t_eval=t, progress=progress)
    kin = cache[key]
    row = {"name": v.name, "contact": contact.describe(),
           **_kinematic_metrics(spec, model, motion, t, kin)}
    driven = None
    if knee.sides and kin.status is Status.COMPLETED:
        driven = knee_run(model, motion, kin, contact.law, ground_z=spec.ground_z,
                          sides=knee.sides, source=knee.moment, passive=passive,
                          fall=spec.fall, options=spec.integrator, t_eval=t,
                          progress=progress)
        n = len(driven.run.t)
        cols = [model.coordinate_index(f"knee_{s[0]}") for s in knee.sides]
        dev = np.degrees(np.abs(driven.run.q[:, cols] - kin.run.q[:n, cols]))
        row["knee_run"] = {
            "sides": list(knee.sides), "moment": knee.moment.value,
            "passive": [vars(e) for e in passive.elements], "status": driven.status.value,
            "time_to_fall_s": driven.time_to_fall, "fall_cause": driven.fall_cause,
            "end_time_s": float(driven.run.t[-1]),
            "max_knee_deviation_deg": float(np.max(dev)) if dev.size else 0.0}
    row["time_to_fall_s"] = driven.time_to_fall if driven is not None else None
    return row, kin, driven


def _plot(folder: Path, model, motion, kin: Gait7Result, driven: Gait7Result | None,
          interval: float) -> None:
    from predgait.report.raster import Line, Panel, save_chart
    from predgait.report.simulation_plots import COLORS, MEASURED
    from predgait.report.stick import save_stick_chart
    from predgait.report.viewer import contact_grf, write_motion

    t = kin.run.t
    rows = np.searchsorted(motion.plate_time, t)
    z = model.coordinate_index("base_z")
    runs = [("simulated (kinematic)", kin, COLORS[0])]
    if driven is not None:
        runs.append(("knee driven", driven, COLORS[1]))
    panels = [Panel((Line(t, motion.plate_fz[side][rows], color=MEASURED, label="force plate"),
                     *(Line(r.run.t, r.foot_fz(side), color=c, width=1.0, label=label)
                       for label, r, c in runs)), ylabel=f"{side} vertical GRF (N)")
              for side in SIDES]
    window = (motion.time >= t[0]) & (motion.time <= t[-1])
    panels.append(Panel((Line(motion.time[window], motion.q[window, z], color=MEASURED,
                              label="measured hip centre"),
                         *(Line(r.run.t, r.run.q[:, z], color=c, width=1.0, label=label)
                           for label, r, c in runs)),
                        ylabel="HAT height (m)", xlabel="trial time (s)"))
    save_chart(folder / "grf.png", panels, size=(7, 8), columns=1, hspace=0.25)
    save_stick_chart(folder / "stick.png", model, t, {"": kin.run.q}, interval=interval)
    measured = motion.q[np.clip(np.searchsorted(motion.time, t), 0, len(motion.time) - 1)]
    feet = contact_grf(model, kin.run.q, kin.forces, CONTACT_FRAMES,
                       [[f for f in CONTACT_FRAMES if f.endswith(f"_{s[0]}")] for s in SIDES])
    write_motion(folder, model, t, kin.run.q, reference_q=measured,
                 grf=dict(zip((f"{s} foot" for s in SIDES), feet, strict=True)))


def _plot_knees(folder: Path, model, kin: Gait7Result, results) -> None:
    """knee.png: knee angles of the knee-driven runs vs the kinematic run (grey).

    A dot marks where a knee-driven run stopped early (e.g. a fall).
    """
    from predgait.report.raster import Line, Panel, save_chart
    from predgait.report.simulation_plots import COLORS

    def flexion_deg(run, side):
        name = f"knee_{side[0]}"
        return np.degrees(clinical_joint(model, name).clinical(
            run.q[:, model.coordinate_index(name)]))

    lines = []
    for side, grey in zip(SIDES, ("#999999", "#cccccc"), strict=True):
        lines.append(Line(kin.run.t, flexion_deg(kin.run, side), color=grey, width=2.5,
                          label=f"{side} knee, kinematic"))
    for i, (row, _, driven) in enumerate(results):
        if driven is None:
            continue
        color = COLORS[i % len(COLORS)]
        for side in row["knee_run"]["sides"]:
            angle = flexion_deg(driven.run, side)
            lines.append(Line(driven.run.t, angle, color=color, width=1.0,
                              label=f"{row['name']} ({side})"))
            if driven.status is not Status.COMPLETED:
                lines.append(Line(driven.run.t[-1:], angle[-1:], color=color, width=0.0,
                                  dots=6.0))
    save_chart(folder / "knee.png", [Panel(tuple(lines), xlabel="trial time (s)",
                                           ylabel="knee flexion (deg)")], size=(7, 4))


def _write_states(folder: Path, name: str, model, result: Gait7Result, header: dict) -> None:
    run = result.run
    cols = {n: run.q[:, i] for i, n in enumerate(model.coordinate_names)}
    cols |= {f"{n}_speed": run.v[:, i] for i, n in enumerate(model.coordinate_names)}
    partial = "_partial" if result.status is Status.DIVERGED else ""
    write_storage(folder / f"{name}{partial}.sto", run.t, cols,
                  header={"units": "m, rad, m/s, rad/s", "status": result.status.value} | header)


def run_gait7(spec: Gait7Spec, folder: Path, *, progress: bool = False) -> dict:
    """Run the main settings and the variants into ``folder``; returns the summary."""
    model = gait7_model(spec.mass, spec.height)
    motion = bundled_gait7_motion(model)
    t = _window(spec, motion)
    cache: dict = {}
    results = [_run_variant(spec, v, model, motion, t, cache, progress and i == 0)
               for i, v in enumerate((Gait7Variant("main"), *spec.variants))]
    rows = [r[0] for r in results]
    main_kin, main_knee = results[0][1], results[0][2]
    header = {"trial": motion.provenance.get("trial", ""), "model": model.source}
    _write_states(folder, "states", model, main_kin, header)
    write_osim2d_motion(folder / "motion.mot", model, main_kin.run.t, main_kin.run.q,
                        header=header | {"status": main_kin.status.value})
    if main_knee is not None:
        _write_states(folder, "states_knee", model, main_knee, header)
    rt = np.searchsorted(motion.plate_time, main_kin.run.t)
    columns = {f"simulated_{s}_fz": main_kin.foot_fz(s) for s in SIDES}
    columns |= {f"measured_{s}_fz": motion.plate_fz[s][rt] for s in SIDES}
    columns |= {f"simulated_{f}_fz": main_kin.forces[:, i, 2]
                for i, f in enumerate(CONTACT_FRAMES)}
    write_storage(folder / "grf.sto", main_kin.run.t, columns, header={"units": "N"} | header)
    write_csv(folder / "grf.csv", main_kin.run.t, columns, units=dict.fromkeys(columns, "N"),
              provenance=f"{header['trial']}; {model.source}; {spec.source}")
    if plots_wanted():
        _plot(folder, model, motion, main_kin, main_knee, spec.stick_interval)
        _plot_knees(folder, model, main_kin, results)
    main = rows[0]
    summary = {"kind": "gait7", "status": "diverged" if main_kin.status is Status.DIVERGED
               else "completed",
               "message": main_kin.fall_cause or "kinematic run completed",
               "integrator": {"method": spec.integrator.method.value,
                              "step_s": spec.integrator.step, "rtol": spec.integrator.rtol,
                              "atol": spec.integrator.atol},
               "time_span_s": [float(t[0]), float(t[-1])], "ground_z_m": spec.ground_z,
               "time_to_fall_s": main["time_to_fall_s"], "grf": main["grf"], "runs": rows,
               "provenance": {"problem": source_name(spec.source), "predgait": __version__,
                              "model": model.source, **motion.provenance}}
    weight = model.total_mass() * model.gravity
    peak = max(float(np.max(main_kin.foot_fz(s))) for s in SIDES)
    return write_summary(folder / "summary.json", record(summary, [
        grf_check(peak / weight, "peak vertical ground reaction (simulated, one foot)")]))

