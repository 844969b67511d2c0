"""``predgait demo``: the main job on the bundled real trial, with no argument.

Stages (each a sub-folder of --out, then one HTML report of them all):
  1. inverse dynamics of the bundled subject01 right leg (problems/inverse_subject01.toml);
  2. forward re-synthesis driven by those moments, with the thesis' passive knee elements
     (problems/resynthesis.toml);
  3. the passive knee and ankle: swing angles and quiet moments fitted together, one answer
     per joint, or what the trial cannot identify (problems/passive_knee_ankle.toml);
  4. torque correction (CasADi + Ipopt), checked by Pinocchio re-simulation
     (problems/torque_correction.toml);
  5. a what-if scenario: a stiffer knee, driven by the corrected torques with fitted
     feedback gains (problems/scenario_stiff_knee.toml).
The problem files used are written into the result folder, next to their results.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from predgait.errors import InputError

DEFAULT_OUT = Path("predgait-demo")

RESYNTHESIS = """\
# Re-synthesis of the bundled walk, right leg (thesis 4.2, Fig. 4.2.9); see problems/.
kind = "resynthesis"
[trial]
source = "bundled:subject01"
side = "right"
[integrator]
method = "modified_euler"
step = 0.001
iterations = 10
[simulation]
start = 0.0
duration = 1.2
threshold_deg = 5.0
stick_interval = 0.05
[fall]
segment_angle_deg = 80.0
[stability]
times = [0.05, 0.2, 0.4]
[[variants]]
name = "knee k=10 c=20"
passive = { knee = { k = 10.0, c = 20.0 } }
[[variants]]
name = "knee k=100 c=100"
passive = { knee = { k = 100.0, c = 100.0 } }
"""

SOLVE = """\
# {kind} of the bundled walk, right leg; see problems/{kind}.toml.
kind = "{kind}"
window = [0.0, 1.0]
nodes = 200
[trial]
source = "bundled:subject01"
side = "right"
[check]
threshold_deg = 2.0
"""

PASSIVE = """\
# The passive knee and ankle of the bundled walk, right leg; see problems/passive_knee_ankle.toml.
kind = "passive_knee_ankle"
joints = ["knee", "ankle"]
quiet_phases = [[73.0, 95.0]]
window_sensitivity = [[73.0, 87.0], [73.0, 95.0], [73.0, 100.0]]
[trial]
source = "bundled:subject01"
side = "right"
[filter]
marker_cutoff = 20.0
sensitivity_hz = [10.0, 15.0]
[simulation]
max_iter = 200
[uncertainty]
bootstrap = 0
[passive.knee]
elements = ["linear", "limits"]
fit = ["k", "c", "theta0"]
[passive.ankle]
elements = ["linear", "limits"]
fit = ["k", "c", "theta0"]
"""

SCENARIO = """\
# What-if: a stiffer knee; see problems/scenario_stiff_knee.toml.
name = "stiffer knee"
trial = "bundled:subject01"
side = "right"
window = [0.0, 1.0]
[control]
torques = "corrected"
gains = "fitted"
[[edit]]
kind = "passive"
joint = "knee"
k = 100.0
c = 2.0
theta0_deg = 10.0
"""
MARKER = ".predgait-demo"
INTRO = ("A walk-through of predgait on the bundled OpenSim subject01 walk (72.6 kg, right "
         "leg): inverse dynamics; forward re-synthesis driven by those moments, and why it "
         "drifts; the passive knee and ankle, or what the trial cannot identify of them; "
         "corrected torque histories; a what-if scenario. "
         "The paragraph under each step's numbers is written from that step's results.")


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


def _stage(name: str, started: float, last: list[float]) -> None:
    """Print a stage's own time and the total so far (``last`` holds the previous end)."""
    now = time.perf_counter()
    print(f"  {name:<38} {now - last[0]:6.1f} s  (total {now - started:6.1f} s)")
    last[0] = now


def run(args: argparse.Namespace) -> int:
    """Run every stage into a staging folder, then write the report."""
    from predgait.cli.scenario import write_scenario
    from predgait.dynamics.inverse_trial import bundled_inverse
    from predgait.models.urdf import write_text_atomic
    from predgait.problemfile import load_problem
    from predgait.report.html import build_report
    from predgait.scenarios.run import load_scenario, run_scenario
    from predgait.workflows.inverse_io import write_inverse_outputs
    from predgait.workflows.output import staged_output
    from predgait.workflows.passive_swing import parse_knee_ankle
    from predgait.workflows.passive_swing import run_swing as run_passive
    from predgait.workflows.simulate import parse_spec
    from predgait.workflows.simulate_run import run_spec
    from predgait.workflows.solve import parse_solve, run_solve

    out = args.out
    replace = out.exists() and (out / MARKER).is_file()
    if out.exists() and not replace:
        raise InputError(f"{out} exists and is not a previous demo folder; choose --out DIR.")
    print(f"predgait demo: bundled trial subject01 (OpenSim Gait2354 example), right leg -> {out}/")
    with staged_output(out, force=replace) as stage:
        (stage / MARKER).write_text("written by predgait demo; replaced by the next demo\n")
        started = time.perf_counter()
        last = [started]
        result = bundled_inverse("right")
        write_inverse_outputs(result, stage / "01_inverse_dynamics")
        _stage("1 inverse dynamics", started, last)
        problems = stage / "problems"
        problems.mkdir()
        (problems / "resynthesis.toml").write_text(RESYNTHESIS)
        (problems / "scenario_stiff_knee.toml").write_text(SCENARIO)
        folder = stage / "02_resynthesis"
        folder.mkdir()
        run_spec(parse_spec(problems / "resynthesis.toml"), folder)
        _stage("2 forward re-synthesis", started, last)
        (problems / "passive_knee_ankle.toml").write_text(PASSIVE)
        run_passive(parse_knee_ankle(load_problem(problems / "passive_knee_ankle.toml")),
                    stage / "03_passive_knee_ankle")
        _stage("3 passive knee and ankle", started, last)
        path = problems / "torque_correction.toml"
        path.write_text(SOLVE.format(kind="torque_correction"))
        run_solve(parse_solve(load_problem(path)), stage / "04_torque_correction")
        _stage("4 torque correction", started, last)
        write_scenario(run_scenario(load_scenario(problems / "scenario_stiff_knee.toml")),
                       stage / "05_scenario_stiff_knee")
        _stage("5 scenario: stiffer knee", started, last)
        write_text_atomic(build_report(stage, title="predgait demo: subject01 right leg",
                                       source=out.name, intro=INTRO), stage / "report.html")
    print(f"wrote {out}/report.html (open it in a browser)")
    _print_warnings(out)
    return 0


def _print_warnings(out: Path) -> None:
    """Each result's plausibility warnings (analysis.plausibility), under its folder name."""
    import json

    from predgait.analysis.plausibility import warning_lines
    from predgait.report.headline import summary_file

    for folder in sorted(p for p in out.iterdir() if p.is_dir()):
        path = summary_file(folder)
        lines = warning_lines(json.loads(path.read_text())) if path else []
        if lines:
            print(f"  {folder.name}: {len(lines)} plausibility warning(s)")
            for line in lines:
                print(f"  {line}")
