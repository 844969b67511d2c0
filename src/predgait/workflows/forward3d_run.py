"""Run a ``kind = "fullbody"`` spec and write its result folder.

Whole-body IK + ID of the trial, then one forward simulation per variant.

Files: ``states_<variant>.sto`` per variant (``..._partial.sto`` if it diverged; pelvis
position m, pelvis Cardan X-Y-Z and joint angles deg, like ``kinematics3d.sto``),
``summary.json`` (per variant: status, time to fall and what fell, deviations from the
measured motion, fastest linear growth at the start, peak PD feedback and measured moment
per fed-back joint; plausibility: per variant with feedback, the joint whose feedback
most exceeds its measured peak moment), ``fullbody.png`` and ``stick.gif``
(sagittal stick figure of the longest run, measured motion in grey).
"""

from __future__ import annotations

import re
from pathlib import Path

from predgait import __version__
from predgait.analysis.plausibility import record, worst_feedback_check
from predgait.data import read_trc, write_storage
from predgait.dynamics.integrators import Status
from predgait.errors import InputError
from predgait.kinematics.ik3d import coordinate_columns
from predgait.report.tidy import write_summary
from predgait.simulations.forward3d import Forward3DRun, FullbodyDrive, simulate_fullbody
from predgait.workflows.forward3d_spec import FullbodySpec, TrialSpec
from predgait.workflows.trials import bundled_fullbody_files


def inverse_for(trial: TrialSpec):
    """Whole-body IK + ID of the spec's trial (an Inverse3DResult)."""
    from predgait.dynamics.inverse3d_trial import inverse_fullbody, read_marker_map, read_trial

    if trial.files is None:
        files, static, mass, height = bundled_fullbody_files(trial.static)
        mass, height = trial.mass or mass, trial.height or height
    else:
        files, static, mass, height = trial.files, trial.static, trial.mass, trial.height
    markers, plates = read_trial(files)
    return inverse_fullbody(markers, plates, read_marker_map(trial.marker_map), mass=mass,
                            height=height, sex=trial.sex,
                            static=read_trc(static) if static else None, cutoff=trial.cutoff)


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_").lower() or "run"


def write_states(folder: Path, run: Forward3DRun, joint_names, header: dict) -> Path:
    """``states_<variant>.sto`` (``_partial`` if it diverged): m and deg."""
    cols = coordinate_columns(run.q, joint_names)
    tail = "_partial" if run.status is Status.DIVERGED else ""
    path = folder / f"states_{_slug(run.mode.name)}{tail}.sto"
    write_storage(path, run.t, cols, in_degrees=True, header=header | {
        "variant": run.mode.name, "status": run.status,
        "units": "deg (angles: Cardan X-Y-Z), m (pelvis_t*)"})
    return path


def _row(run: Forward3DRun, t0: float) -> dict:
    rate, lead = run.growth
    return {"name": run.mode.name, "pelvis": run.mode.pelvis.value,
            "joints": run.mode.joints.value, "ground": run.mode.ground.value,
            "kinematic_joints": list(run.mode.kinematic_joints), "status": run.status,
            "time_to_fall_s": run.time_to_fall, "fall_criterion": run.fall_criterion,
            "simulated_s": float(run.t[-1] - t0), "step_s": run.mode.step,
            "message": run.message,
            "growth_at_start": {"rate_per_s": rate,
                                "e_folding_s": 1.0 / rate if rate > 1e-2 else None,
                                "leading_state": lead},
            "floor_z_m": run.ground_z, "belt_velocity_m_per_s": run.belt_velocity,
            "deviation": run.deviation,
            "peak_feedback_n_m": dict(run.feedback_peak),
            "peak_measured_moment_n_m": dict(run.measured_peak)}


def _run_variants(spec: FullbodySpec, bar):
    """IK + ID of the trial, then every variant; (drive, inverse, runs, t0, t1)."""
    inverse = inverse_for(spec.trial)
    drive = FullbodyDrive.from_inverse(inverse)
    bar.update()
    t0 = spec.start if spec.start is not None else next(iter(drive.heel_strikes),
                                                         float(drive.time[0]))
    t1 = t0 + spec.duration
    if not drive.time[0] <= t0 < t1 <= drive.time[-1] + 1e-9:
        raise InputError(f"{spec.source}: simulation {t0:g}..{t1:g} s (simulation.start, "
                         f"simulation.duration) is outside the trial {drive.time[0]:.3f}.."
                         f"{drive.time[-1]:.3f} s.")
    missing = [f for f in spec.contact.frames if not drive.model.pin_model.existFrame(f)]
    if missing:
        raise InputError(f"{spec.source}: contact.frames: the model has no frame "
                         f"{missing[0]!r}; use sole points such as "
                         "\"heel_contact_r\", \"toe_contact_r\" or marker frames.")
    runs = []
    for mode in spec.variants:
        bar.set_description(mode.name)
        options = mode.integrator(spec.integrator)
        runs.append(simulate_fullbody(drive, mode, (t0, t1), options=options, fall=spec.fall,
                                      contact=spec.contact, band_deg=spec.band_deg,
                                      band_m=spec.band_m))
        bar.update()
    return drive, inverse, runs, t0, t1


def run_fullbody(spec: FullbodySpec, folder: Path, *, progress: bool = False) -> dict:
    """Run every variant of ``spec`` into ``folder``; returns the summary."""
    from tqdm import tqdm

    from predgait.report.figures import plots_wanted, save_figure
    from predgait.report.fullbody_plots import plot_fullbody_runs
    from predgait.report.viewer import plate_arrows, write_motion

    # One bar for the whole command (IK + ID, then each variant); hidden when stderr is
    # not a terminal.
    with tqdm(total=1 + len(spec.variants), desc="whole-body IK + ID", unit="step",
              disable=None if progress else True, leave=False) as bar:
        drive, inverse, runs, t0, t1 = _run_variants(spec, bar)
    names = drive.model.joint_names
    prov = {"problem": spec.source, "trial": drive.source, "predgait": __version__,
            "model": inverse.provenance.get("model", "")}
    header = {"provenance": "; ".join(f"{k}={v}" for k, v in prov.items()),
              "start_s": f"{t0:.6g}"}
    for run in runs:
        write_states(folder, run, names, header)
    if plots_wanted():
        save_figure(plot_fullbody_runs(runs, names, t0=t0), folder / "fullbody.png")
        longest = max(runs, key=lambda run: run.t[-1])  # the first of the longest runs
        write_motion(folder, drive.model, longest.t, longest.q, reference_q=longest.measured,
                     label=f"simulated: {longest.mode.name}",
                     grf=plate_arrows(inverse.plates, inverse.ik.time, longest.t,
                                      prefix="measured plate") or None)
    rows = [_row(run, t0) for run in runs]
    options = spec.integrator
    summary = {
        "kind": "fullbody",
        "status": str(Status.DIVERGED if any(r.status is Status.DIVERGED for r in runs)
                      else Status.COMPLETED),
        "message": "; ".join(f"{r.mode.name}: {r.message}" for r in runs),
        "time_to_fall_s": runs[0].time_to_fall, "time_span_s": [t0, t1],
        "integrator": {"method": options.method.value, "step_s": options.step,
                       "iterations": options.iterations, "rtol": options.rtol,
                       "atol": options.atol},
        "fall_limits": vars(spec.fall), "runs": rows, "provenance": prov}
    return write_summary(folder / "summary.json", record(summary, [
        worst_feedback_check(r.feedback_peak, r.measured_peak,
                             what=f"feedback torque ({r.mode.name})")
        for r in runs if r.feedback_peak]))
