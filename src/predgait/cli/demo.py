"""``predgait demo``: the main job on the bundled real trial, with no argument.

Stages (each a sub-folder of --out, then one HTML report of them all):
  1. inverse dynamics of the bundled subject01 right leg (problems/inverse_subject01.toml).
Later stages are added as the forward, optimisation and scenario commands land.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from predgait.errors import InputError

DEFAULT_OUT = Path("predgait-demo")
MARKER = ".predgait-demo"


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``demo``."""
    demo = commands.add_parser(
        "demo", help="run the pipeline on the bundled trial (no argument needed)",
        description="Run the pipeline on the bundled OpenSim subject01 walk (72.6 kg, 1.80 m, "
                    "right leg) and write every result and report.html into --out.")
    demo.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                      help=f"result folder (default ./{DEFAULT_OUT}; a previous demo folder "
                           "is replaced)")
    demo.set_defaults(run=run)


def _stage(name: str, started: float) -> None:
    print(f"  {name:<38} {time.perf_counter() - started:6.1f} s")


def run(args: argparse.Namespace) -> int:
    """Run every stage into a staging folder, then write the report."""
    from predgait.models.urdf import write_text_atomic
    from predgait.report.html import build_report
    from predgait.workflows.inverse import bundled_inverse
    from predgait.workflows.inverse_io import write_inverse_outputs
    from predgait.workflows.output import staged_output

    out = args.out
    replace = out.exists() and (out / MARKER).is_file()
    if out.exists() and not replace:
        raise InputError(f"{out} exists and is not a previous demo folder; choose --out DIR.")
    print(f"predgait demo: bundled trial subject01 (OpenSim Gait2354 example), right leg -> {out}/")
    with staged_output(out, force=replace) as stage:
        (stage / MARKER).write_text("written by predgait demo; replaced by the next demo\n")
        started = time.perf_counter()
        result = bundled_inverse("right")
        write_inverse_outputs(result, stage / "01_inverse_dynamics")
        _stage("1 inverse dynamics", started)
        write_text_atomic(build_report(stage, title="predgait demo: subject01 right leg",
                                       source=str(out.resolve())),
                          stage / "report.html")
    print(f"wrote {out}/report.html (open it in a browser)")
    return 0
