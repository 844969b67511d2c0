"""``predgait model build|show``: generate and inspect URDF models."""

from __future__ import annotations

import argparse
from pathlib import Path

from predgait.models.describe import format_model
from predgait.models.loading import DEFAULT_SUBJECT, generate_urdf, load_model
from predgait.models.urdf import write_text_atomic

BUILD_HELP = """\
Generate a URDF from anthropometry (SI units).

  leg: foot, shank and thigh of the thesis (section 3.3, Table 3.3.2 = Winter 1990),
       from --mass (kg) and --height (m), or from --segments FILE.csv with columns
       segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2 (rows foot, shank, thigh;
       foot length is heel to toe and its COM fraction is from the heel).
  rod: the thesis' uniform slender rod (section 3.2), from --mass (kg) and --length (m).
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``model build`` and ``model show``."""
    model = commands.add_parser("model", help="build a URDF model or show one",
                                description="Build a URDF model from anthropometry or show one.")
    sub = model.add_subparsers(dest="model_command", metavar="ACTION", required=True)
    build = sub.add_parser("build", help="generate a URDF from anthropometry",
                           description=BUILD_HELP,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    build.add_argument("kind", choices=("rod", "leg"), help="model kind")
    build.add_argument("--mass", type=float, metavar="KG",
                       help=f"body mass in kg, 20-300 (leg; default {DEFAULT_SUBJECT['mass']}) "
                            "or rod mass in kg (default: the thesis rod)")
    build.add_argument("--height", type=float, metavar="M",
                       help=f"standing height in m, 0.5-2.5 (leg; default "
                            f"{DEFAULT_SUBJECT['height']})")
    build.add_argument("--length", type=float, metavar="M", help="rod length in m (rod only)")
    build.add_argument("--segments", type=Path, metavar="CSV",
                       help="segment parameter table (leg only) instead of regressions")
    build.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.urdf",
                       help="output URDF path")
    build.add_argument("--force", action="store_true", help="overwrite an existing output file")
    build.set_defaults(run=run_build)
    show = sub.add_parser("show", help="print segments, joints and frames of a URDF",
                          description="Print the segment table (mass kg, length m, COM m, "
                                      "inertia kg m^2), joints with limits and frames.")
    show.add_argument("urdf", help="a URDF made by 'predgait model build', or 'leg' / 'rod'")
    show.set_defaults(run=run_show)


def run_build(args: argparse.Namespace) -> int:
    """Generate, validate (by loading it) and write the URDF."""
    from predgait.errors import InputError
    from predgait.models.loading import model_from_urdf

    if args.kind == "rod" and (args.height is not None or args.segments is not None):
        raise InputError("the rod takes --mass and --length, not --height or --segments.")
    if args.kind == "leg" and args.length is not None:
        raise InputError("the leg takes --mass and --height (or --segments), not --length.")
    text = generate_urdf(args.kind, mass=args.mass, height=args.height, length=args.length,
                         segments=args.segments)
    model_from_urdf(text, source=str(args.output))
    write_text_atomic(text, args.output, force=args.force)
    print(f"wrote {args.output}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    """Print the model tables."""
    print(format_model(load_model(args.urdf)))
    return 0
