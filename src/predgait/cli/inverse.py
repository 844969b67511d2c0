"""``predgait inverse``: planar inverse dynamics of a measured trial."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from predgait.cli import add_output_options
from predgait.errors import InputError

DESCRIPTION = """\
Planar inverse dynamics of one leg (thesis 3.3.3; Pinocchio RNEA with the measured ground
reaction on the foot). Writes kinematics.sto/.csv (hip_flexion, knee_flexion,
ankle_dorsiflexion, rad), inverse_dynamics.sto/.csv (moments N m, joint forces N, powers W,
ground reaction), summary.json and PNG plots against % gait cycle into --out.

Give either a TOML problem file (problems/inverse_*.toml: joint-centre rules, static trial)
or a marker file (TRC, C3D or CSV with NAME_x/_y/_z columns) and the options below.
With a problem file, an option given on the command line replaces the file's key
(--mass -> trial.mass, --cutoff -> options.cutoff, ...), and --set KEY=VALUE sets any key.
Time zero is heel strike of the analysed foot.

Frames the model cannot follow (inverse kinematics on a joint limit, or not converged) are
flagged: their results are NaN in the tables and gaps in the plots, and the run reports
"completed with N flagged frames". When most frames are flagged the run fails (exit 3)
after writing its outputs; --limit-margin widens the model's joint ranges.
"""

#: The usage line: each way to call it with the options it requires (argparse would show
#: --mass and --markers as optional, since a problem file gives them instead).
USAGE = """
  %(prog)s PROBLEM.toml --out DIR [--set KEY=VALUE] [options]
  %(prog)s MARKERS.trc|.csv --grf GRF.mot --mass KG --markers hip=NAME,knee=NAME,... --out DIR
  %(prog)s MARKERS.c3d --mass KG --markers hip=NAME,knee=NAME,... --out DIR [options]
  %(prog)s MARKERS --model fullbody --marker-map FILE.toml --mass KG --height M --out DIR"""


def _mass(text: str) -> float | str:
    """``--mass``: a number (kg) or "plates"."""
    if text.strip().lower() == "plates":
        return "plates"
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a mass in kg or 'plates'") from None


def _parse_markers(text: str) -> dict[str, str]:
    pairs = {}
    for item in filter(None, (p.strip() for p in text.split(","))):
        if "=" not in item:
            raise InputError(f"--markers: '{item}' is not POINT=NAME (e.g. hip=RHJC).")
        point, name = (s.strip() for s in item.split("=", 1))
        if point not in ("hip", "knee", "ankle", "heel", "toe"):
            raise InputError(f"--markers: unknown point '{point}'; points: hip, knee, ankle, "
                             "heel, toe.")
        pairs[point] = name
    if "heel" not in pairs and "ankle" in pairs:
        pairs["heel"] = pairs["ankle"]  # the foot is the ankle-toe line
    return pairs


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``inverse``."""
    cmd = commands.add_parser("inverse", help="joint moments from markers and force plates",
                              description=DESCRIPTION, usage=USAGE,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("input", type=Path, help="PROBLEM.toml, or MARKERS.trc|.c3d|.csv")
    cmd.add_argument("--grf", type=Path, help="ground reactions (OpenSim .mot); none for C3D")
    cmd.add_argument("--static", type=Path,
                     help="static trial (TRC): segment lengths (leg) or, with --model fullbody, "
                          "marker calibration and the marker map's [scaling]")
    cmd.add_argument("--mass", type=_mass, metavar="KG|plates",
                     help="body mass, kg (required), or 'plates': weighed on the force plates "
                          "(mean vertical force over a step / g)")
    cmd.add_argument("--height", type=float, metavar="M", help="standing height, m")
    cmd.add_argument("--side", choices=("right", "left"), help="analysed leg (default right)")
    cmd.add_argument("--markers", metavar="hip=NAME,knee=NAME,ankle=NAME,heel=NAME,toe=NAME",
                     help="trial markers (joint centres) of the leg; heel may be omitted")
    cmd.add_argument("--model", type=Path, metavar="LEG.urdf|fullbody",
                     help="leg from 'predgait model build leg' (e.g. custom segments), or "
                          "'fullbody' for 3D inverse kinematics and dynamics of the 35-DOF body "
                          "(needs --marker-map; a problem file's [trial] gives the files, mass "
                          "and height)")
    cmd.add_argument("--marker-map", type=Path, metavar="FILE.toml",
                     help="fullbody: model frames -> trial markers, segment markers, weights, "
                          "[scaling] (problems/markers_fullbody_subject01.toml, "
                          "problems/markers_fullbody_walking5.toml)")
    cmd.add_argument("--sex", choices=("male", "female"), default="male",
                     help="fullbody: de Leva (1996) segment parameters (default male)")
    cmd.add_argument("--cutoff", metavar="HZ|0|auto",
                     help="marker low-pass cut-off, Hz; 0 = unfiltered; auto = Winter's residual "
                          "analysis (default 6; fullbody: of the coordinates)")
    cmd.add_argument("--grf-cutoff", metavar="HZ|0",
                     help="ground-reaction low-pass cut-off, Hz; 0 = unfiltered (default: the "
                          "markers' cut-off for the leg, unfiltered for fullbody as OpenSim's ID "
                          "tool)")
    cmd.add_argument("--threshold", type=float, metavar="N",
                     help="leg: vertical force a contact must reach, N (default 10); it lasts "
                          "while the force stays above half of it")
    cmd.add_argument("--limit-margin", type=float, metavar="DEG",
                     help="widen every joint range of the model by DEG at both ends for the "
                          "inverse kinematics (default 0)")
    add_output_options(cmd, overrides="options.cutoff=0")
    cmd.set_defaults(run=run)


#: Command-line option -> (TOML key, table) it overrides in a problem file.
OVERRIDES = {"grf": ("grf", "trial"), "static": ("static", "trial"), "mass": ("mass", "trial"),
             "height": ("height", "trial"), "side": ("side", "trial"),
             "model": ("model", "trial"), "cutoff": ("cutoff", "options"),
             "grf_cutoff": ("grf_cutoff", "options"), "threshold": ("threshold", "options"),
             "limit_margin": ("limit_margin", "options")}


def _flag_options(args: argparse.Namespace) -> dict:
    """InverseOptions fields given on the command line (parsed), by field name."""
    from predgait.data import Side
    from predgait.data.cutoffs import CutoffRule, parse_cutoff

    given = {k: getattr(args, k) for k in OVERRIDES if getattr(args, k) is not None}
    if "cutoff" in given:
        given["cutoff"] = parse_cutoff(given["cutoff"], field="--cutoff",
                                       rules=(CutoffRule.AUTO,))
    if "grf_cutoff" in given:
        given["grf_cutoff"] = parse_cutoff(given["grf_cutoff"], field="--grf-cutoff")
    if "side" in given:
        given["side"] = Side(given["side"])
    for name, low, high, unit in (("mass", 20, 300, "kg"), ("height", 0.5, 2.5, "m"),
                                  ("threshold", 0.1, 500, "N"), ("limit_margin", 0, 180, "deg")):
        if name in given and given[name] != "plates" and not low <= given[name] <= high:
            raise InputError(f"--{name.replace('_', '-')} {given[name]:g} {unit} is outside "
                             f"{low:g}..{high:g} {unit}.")
    return given


def options_from_args(args: argparse.Namespace):
    """InverseOptions from a problem file (flags override its keys) or the options alone."""
    from dataclasses import replace

    from predgait.dynamics.inverse_options import InverseOptions
    from predgait.problemfile import load_problem
    from predgait.workflows.inverse_io import options_from_problem

    flags = _flag_options(args)
    if args.input.suffix.lower() == ".toml":
        given = [f"--{name.replace('_', '-')}" for name in ("markers", "marker_map")
                 if getattr(args, name) is not None]
        if given:
            raise InputError(f"{args.input} is a problem file: its [points] table names the "
                             f"markers; drop {', '.join(given)} (or edit the file).")
        options = options_from_problem(load_problem(args.input, overrides=args.set))
        return replace(options, **flags)
    if args.set:
        raise InputError("--set KEY=VALUE changes a problem file's key; give a PROBLEM.toml "
                         "or use the options directly.")
    if args.mass is None:
        raise InputError("--mass (kg) is required: joint moments depend on the body mass "
                         "(--mass plates weighs the subject on the force plates).")
    if not args.markers:
        raise InputError("--markers is required with a marker file, e.g. "
                         "--markers hip=RHJC,knee=RKJC,ankle=RAJC,heel=RCAL,toe=RMT2.")
    if not args.input.is_file():
        raise InputError(f"{args.input}: file not found.")
    return InverseOptions(markers=args.input, points=_parse_markers(args.markers), **flags)


def _trial_from_problem(args: argparse.Namespace) -> None:
    """Fill the full-body run's files, mass and height from a problem file's ``[trial]``.

    Flags given on the command line win; the leg's ``[points]`` are not used (the marker
    map names the full-body markers).
    """
    from predgait.problemfile import load_problem
    from predgait.workflows.inverse_io import options_from_problem

    options = options_from_problem(load_problem(args.input, overrides=args.set))
    args.input = options.markers
    for name in ("grf", "static", "mass", "height"):
        if getattr(args, name) is None:
            setattr(args, name, getattr(options, name))


def run_fullbody(args: argparse.Namespace) -> int:
    """3D inverse kinematics and dynamics of the whole body (35 DOF)."""
    from predgait.workflows.inverse3d import run_inverse_fullbody

    if args.marker_map is None:
        raise InputError("--model fullbody needs --marker-map FILE.toml (see "
                         "problems/markers_fullbody_subject01.toml).")
    unused = [flag for flag, value in (("--threshold", args.threshold), ("--markers", args.markers),
                                       ("--side", args.side)) if value]
    if unused:
        raise InputError(f"{', '.join(unused)}: not used by --model fullbody (the marker map "
                         "names the markers, plates are assigned to both feet); drop them.")
    if args.input.suffix.lower() == ".toml":
        _trial_from_problem(args)
    elif args.set:
        raise InputError("--set KEY=VALUE changes a problem file's key; give a PROBLEM.toml "
                         "or use the options directly.")
    if args.mass is None or args.height is None:
        raise InputError("--model fullbody needs --mass (kg) and --height (m), on the command "
                         "line or in a problem file's [trial] table.")
    from predgait.data.cutoffs import parse_cutoff

    if args.limit_margin is not None and not 0 <= args.limit_margin <= 180:
        raise InputError(f"--limit-margin {args.limit_margin:g} deg is outside 0..180 deg.")
    cutoff = parse_cutoff(args.cutoff if args.cutoff is not None else 6.0, field="--cutoff")
    grf_cutoff = parse_cutoff(args.grf_cutoff or 0, field="--grf-cutoff")
    files = [args.input] + ([args.grf] if args.grf else [])
    summary = run_inverse_fullbody(files, args.marker_map, mass=args.mass, height=args.height,
                                   sex=args.sex, out_dir=args.out, static=args.static,
                                   cutoff=cutoff, grf_cutoff=grf_cutoff,
                                   limit_margin=args.limit_margin or 0.0, force=args.force)
    from predgait.analysis.plausibility import warning_lines
    from predgait.dynamics.inverse_options import MOST_FRAMES
    from predgait.report.console import inverse3d_text

    print(inverse3d_text(summary, args.out))
    print(f"  status: {summary['status']}")
    for line in warning_lines(summary):
        print(line)
    flagged = len(summary.get("ik_flagged_frames") or [])
    if flagged > MOST_FRAMES * summary["frames"]:
        print(f"predgait: error: inverse kinematics flagged {flagged} of {summary['frames']} "
              f"frames (the model cannot follow the markers there); the results in "
              f"{args.out}/ are NaN at those frames. Check the marker map.", file=sys.stderr)
        return 3
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the pipeline and write the result folder."""
    from predgait.analysis.plausibility import warning_lines
    from predgait.dynamics.inverse_options import MOST_FRAMES
    from predgait.dynamics.inverse_trial import run_inverse
    from predgait.workflows.inverse_io import summary, write_inverse_outputs
    from predgait.workflows.output import check_out

    given = [args.input, args.grf, args.static, args.marker_map]
    if args.model is not None and str(args.model) != "fullbody":
        given.append(args.model)
    check_out(args.out, force=args.force, inputs=given)  # before any computation
    if args.model is not None and str(args.model) == "fullbody":
        return run_fullbody(args)
    options = options_from_args(args)
    result = run_inverse(options)
    inputs = [p for p in (options.markers, options.grf, options.static) if p]
    write_inverse_outputs(result, args.out, force=args.force, inputs=inputs)
    info = summary(result)
    peaks = info["peak_moments_n_m_per_kg"]
    print(f"inverse dynamics of the {result.side} leg, {result.time.size} frames "
          f"({info['window']}): {info['status']}; wrote {args.out}/")
    if info["flagged_frames"]:
        limits = info["flagged_frames_at_joint_limits"]
        print(f"  flagged frames (results NaN): {info['flagged_frames']} of {result.time.size}"
              + (f"; held at a joint limit: {limits}" if limits else ""))
    if not result.has_grf:
        print("  no ground reaction in this trial: stance-phase moments are not valid.")
    for joint in ("hip_flexion", "knee_flexion", "ankle_dorsiflexion"):
        low, high = peaks[joint + "_moment_min"], peaks[joint + "_moment_max"]
        if low is not None:
            print(f"  {joint}_moment: {low:+.2f} .. {high:+.2f} N m/kg")
    for line in warning_lines(info):
        print(line)
    if info["flagged_frames"] > MOST_FRAMES * result.time.size:
        print(f"predgait: error: inverse kinematics flagged {info['flagged_frames']} of "
              f"{result.time.size} frames (the model cannot follow the markers there); the "
              f"results in {args.out}/ are NaN at those frames. Check the marker names, or "
              "widen the joint ranges with --limit-margin DEG.", file=sys.stderr)
        return 3
    return 0
