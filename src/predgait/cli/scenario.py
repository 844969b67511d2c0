"""``predgait scenario``: predict the gait after a model edit (surgery, orthosis, cast)."""

from __future__ import annotations

import argparse
from pathlib import Path

from predgait.cli import add_output_options

DESCRIPTION = """\
Edit the leg (scale a segment, move a COM, add mass, add a passive element such as an
ankle-foot orthosis or a stiffer knee, restrict a range of motion, lock a joint), re-simulate
the measured walk with the same drive and PD control, and compare with the unedited leg.
Writes summary.json (metrics), states_baseline.sto, states_edited.sto, edited_leg.urdf and
comparison plots into --out. Example files: problems/scenario_*.toml.
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``scenario``."""
    cmd = commands.add_parser("scenario", help="what-if: edit the model, predict the gait",
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("scenario", type=Path, help="SCENARIO.toml")
    add_output_options(cmd, overrides="edit.0.k=200")
    cmd.set_defaults(run=run)


def write_scenario(result, out: Path, *, force: bool = False) -> None:
    """Write the scenario's result folder whole or not at all."""
    from predgait.data import write_storage
    from predgait.report.figures import plots_wanted
    from predgait.report.scenario_plots import save_scenario_plot
    from predgait.report.tidy import write_summary
    from predgait.scenarios.edits import edit_record
    from predgait.workflows.output import staged_output

    with staged_output(out, force=force, inputs=[result.spec.source]) as stage:
        summary = {"status": result.metrics["status"], "scenario": result.spec.name,
                   "trial": "bundled:subject01", "side": result.spec.side,
                   "torques": result.spec.torques.value, "gains": result.spec.gains.value,
                   "edits": [edit_record(e) for e in result.spec.edits],
                   "window_s": list(result.spec.window),
                   "control": {"kp_n_m_per_rad": result.spec.kp,
                               "kd_n_m_s_per_rad": result.spec.kd},
                   "metrics": result.metrics}
        write_summary(stage / "summary.json", summary)
        for name, sim in (("baseline", result.baseline), ("edited", result.edited)):
            columns = {n: sim.q[:, i] for i, n in enumerate(sim.coordinate_names)}
            columns |= {f"{n}_speed": sim.qd[:, i] for i, n in enumerate(sim.coordinate_names)}
            write_storage(stage / f"states_{name}.sto", sim.t, columns,
                          header={"units": "m, rad, m/s, rad/s", "scenario": result.spec.name})
        (stage / "edited_leg.urdf").write_text(result.edited_urdf)
        if plots_wanted():
            save_scenario_plot(stage, result)


def run(args: argparse.Namespace) -> int:
    """Run and write a scenario."""
    from predgait.scenarios.run import load_scenario, run_scenario
    from predgait.workflows.output import check_out

    check_out(args.out, force=args.force, inputs=[args.scenario])  # before any computation
    result = run_scenario(load_scenario(args.scenario, args.set))
    write_scenario(result, args.out, force=args.force)
    m = result.metrics
    print(f"scenario '{result.spec.name}': {m['status']}; wrote {args.out}/")
    if m["status"].startswith("diverged"):
        import sys

        print(f"predgait: error: the scenario {m['status']}, so it has no metrics: "
              f"{m['message']} Partial states in {args.out}/.", file=sys.stderr)
        return 1
    print(f"  knee angle change RMS {m['knee_rms_change_deg']:.1f} deg (max "
          f"{m['knee_max_change_deg']:.1f}); ankle {m['ankle_rms_change_deg']:.1f} deg")
    print(f"  extra feedback torque RMS: knee {m['knee_extra_feedback_rms_n_m']:.1f} N m, "
          f"ankle {m['ankle_extra_feedback_rms_n_m']:.1f} N m")
    return 0
