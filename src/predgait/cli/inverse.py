"""``predgait inverse``: planar inverse dynamics of a measured trial."""

from __future__ import annotations

import argparse
from pathlib import Path

from predgait.cli import add_output_options
from predgait.data import Side
from predgait.errors import InputError

DESCRIPTION = """\
Planar inverse dynamics of one leg (thesis 3.3.3; Pinocchio RNEA with the measured ground
reaction on the foot). Writes kinematics.sto/.csv (hip_flexion, knee_flexion,
ankle_dorsiflexion, rad), inverse_dynamics.sto/.csv (moments N m, joint forces N, powers W,
ground reaction), summary.json and PNG plots against % gait cycle into --out.

Give either a TOML problem file (problems/inverse_*.toml: joint-centre rules, static trial)
or a marker file (TRC, C3D or CSV with NAME_x/_y/_z columns) and the options below.
Time zero is heel strike of the analysed foot.
"""


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
                              description=DESCRIPTION,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    cmd.add_argument("input", type=Path, help="PROBLEM.toml, or MARKERS.trc|.c3d|.csv")
    cmd.add_argument("--grf", type=Path, help="ground reactions (OpenSim .mot); none for C3D")
    cmd.add_argument("--static", type=Path,
                     help="static trial (TRC): segment lengths (leg) or, with --model fullbody, "
                          "marker calibration and the marker map's [scaling]")
    cmd.add_argument("--mass", type=float, metavar="KG", help="body mass, kg (required)")
    cmd.add_argument("--height", type=float, metavar="M", help="standing height, m")
    cmd.add_argument("--side", choices=("right", "left"), default="right")
    cmd.add_argument("--markers", metavar="hip=NAME,knee=NAME,ankle=NAME,heel=NAME,toe=NAME",
                     help="trial markers (joint centres) of the leg; heel may be omitted")
    cmd.add_argument("--model", type=Path, metavar="LEG.urdf|fullbody",
                     help="leg from 'predgait model build leg' (e.g. custom segments), or "
                          "'fullbody' for 3D inverse kinematics and dynamics of the 35-DOF body "
                          "(needs --marker-map)")
    cmd.add_argument("--marker-map", type=Path, metavar="FILE.toml",
                     help="fullbody: model frames -> trial markers, segment markers, weights, "
                          "[scaling] (problems/markers_fullbody_subject01.toml, "
                          "problems/markers_fullbody_walking5.toml)")
    cmd.add_argument("--sex", choices=("male", "female"), default="male",
                     help="fullbody: de Leva (1996) segment parameters (default male)")
    cmd.add_argument("--cutoff", type=float, default=6.0, metavar="HZ",
                     help="marker low-pass cut-off, Hz (default 6)")
    cmd.add_argument("--grf-cutoff", type=float, default=None, metavar="HZ",
                     help="ground-reaction low-pass cut-off, Hz (0 = unfiltered; default 6 for "
                          "the leg, unfiltered for fullbody as OpenSim's ID tool)")
    add_output_options(cmd)
    cmd.set_defaults(run=run)


def options_from_args(args: argparse.Namespace):
    """InverseOptions from a problem file or the command-line options."""
    from predgait.dynamics.inverse_trial import InverseOptions
    from predgait.problemfile import load_problem
    from predgait.workflows.inverse_io import options_from_problem

    if args.input.suffix.lower() == ".toml":
        given = [f"--{name.replace('_', '-')}" for name in
                 ("grf", "static", "mass", "height", "markers", "model", "marker_map")
                 if getattr(args, name) is not None]
        if given:
            raise InputError(f"{args.input} is a problem file: it gives the trial and options; "
                             f"drop {', '.join(given)} (or edit the file).")
        return options_from_problem(load_problem(args.input))
    if args.mass is None:
        raise InputError("--mass (kg) is required: joint moments depend on the body mass.")
    if not args.markers:
        raise InputError("--markers is required with a marker file, e.g. "
                         "--markers hip=RHJC,knee=RKJC,ankle=RAJC,heel=RCAL,toe=RMT2.")
    if not args.input.is_file():
        raise InputError(f"{args.input}: file not found.")
    return InverseOptions(markers=args.input, grf=args.grf, static=args.static, mass=args.mass,
                          height=args.height, side=Side(args.side), model=args.model,
                          points=_parse_markers(args.markers), cutoff=args.cutoff,
                          grf_cutoff=6.0 if args.grf_cutoff is None else args.grf_cutoff or None)


def run_fullbody(args: argparse.Namespace) -> int:
    """3D inverse kinematics and dynamics of the whole body (35 DOF)."""
    from predgait.workflows.inverse3d import run_inverse_fullbody

    if args.marker_map is None:
        raise InputError("--model fullbody needs --marker-map FILE.toml (see "
                         "problems/markers_fullbody_subject01.toml).")
    if args.mass is None or args.height is None:
        raise InputError("--model fullbody needs --mass (kg) and --height (m).")
    files = [args.input] + ([args.grf] if args.grf else [])
    summary = run_inverse_fullbody(files, args.marker_map, mass=args.mass, height=args.height,
                                   sex=args.sex, out_dir=args.out, static=args.static,
                                   cutoff=args.cutoff, grf_cutoff=args.grf_cutoff or None,
                                   force=args.force)
    print(f"3D inverse dynamics of the full body; wrote {args.out}/")
    for key in ("ik_rms_m", "ik_flagged_frames", "pelvis_residual_force_N",
                "pelvis_residual_moment_Nm"):
        print(f"  {key}: {summary.get(key)}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the pipeline and write the result folder."""
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
    peaks = summary(result)["peak_moments_n_m_per_kg"]
    print(f"inverse dynamics of the {result.side} leg, {result.time.size} frames "
          f"({summary(result)['window']}); wrote {args.out}/")
    if not result.has_grf:
        print("  no ground reaction in this trial: stance-phase moments are not valid.")
    for joint in ("hip_flexion", "knee_flexion", "ankle_dorsiflexion"):
        print(f"  {joint}_moment: {peaks[joint + '_moment_min']:+.2f} .. "
              f"{peaks[joint + '_moment_max']:+.2f} N m/kg")
    return 0
