"""``predgait simulate``: forward synthesis from a problem file (rod, collapse, resynthesis)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from predgait.cli import add_output_options

DESCRIPTION = """\
Forward dynamic synthesis (thesis 3.2.4, 3.3.4, 4.1-4.2). PROBLEM.toml says the kind:
  rod          the thesis rod experiment on a synthetic trial: end forces given in the lab
               frame ("inertial") or the rod frame ("body"), and a step-size study;
  collapse     the leg collapsing under its own weight from standing (foot fixed);
  resynthesis  the measured trial driven by its inverse-dynamics moments and hip load,
               foot motion prescribed, with passive-element variants.
  gait7        the planar 7-link model on the measured trial, HAT height free on heel/toe
               contacts: simulated vs measured vertical GRF, knee-driven runs to a fall.
  fullbody     the 35-DOF body driven by its 3D inverse-dynamics moments or IK motions,
               pelvis prescribed/translation/free, measured or contact ground: time to
               fall and deviations per variant (states_<variant>.sto, fullbody.png).
Writes into --out: states.sto (time, coordinates rad/m, then velocities; states_partial.sto
if the run diverged), summary.json (status, integrator, time to fall, RMS), PNG plots,
stick.png (figures every 0.05 s) and stick.gif. Example problem files are in problems/.
Override any value with --set, e.g. --set integrator.step=0.05 --set passive.knee.k=100.
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``simulate``."""
    cmd = commands.add_parser("simulate",
                              help="forward synthesis (rod, collapse, resynthesis, gait7, "
                                   "fullbody)",
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("problem", type=Path, help="problem file (problems/rod.toml, ...)")
    add_output_options(cmd, overrides="passive.knee.k=100")
    cmd.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Parse, run, write the folder whole; exit 1 (with partial states) on divergence."""
    from predgait.analysis.plausibility import warning_lines
    from predgait.report.console import simulate_text
    from predgait.workflows.output import staged_output
    from predgait.workflows.simulate import parse_spec
    from predgait.workflows.simulate_run import run_spec

    spec = parse_spec(args.problem, args.set)
    inputs = [args.problem, getattr(spec, "inverse_problem", None)]
    with staged_output(args.out, force=args.force, inputs=inputs) as stage:
        summary = run_spec(spec, stage, progress=True)
    print(simulate_text(summary, args.out))
    for line in warning_lines(summary):
        print(line)
    if summary["status"] == "diverged":
        print(f"predgait: error: {summary['message']} (partial states written to {args.out})",
              file=sys.stderr)
        return 1
    return 0
