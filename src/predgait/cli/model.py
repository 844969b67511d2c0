"""``predgait model build|show``: generate and inspect URDF models."""

from __future__ import annotations

import argparse
from pathlib import Path

from predgait.models.anthropometry import DEFAULT_SUBJECT
from predgait.models.urdf import check_output_file, write_text_atomic

BUILD_HELP = """\
Generate a URDF from anthropometry (SI units).

  leg: foot, shank and thigh of the thesis (section 3.3, Table 3.3.2 = Winter 1990),
       from --mass (kg) and --height (m), or from --segments FILE.csv with columns
       segment,mass_kg,length_m,com_from_proximal,inertia_kg_m2 (rows foot, shank, thigh;
       foot length is heel to toe and its COM fraction is from the heel); optional columns
       gyration_fraction (instead of the inertia), foot_com = thesis|heel_toe|ankle_toe|
       offset and com_x_m, com_z_m (foot COM from the ankle centre in the foot frame).
  rod: the thesis' uniform slender rod (section 3.2), from --mass (kg) and --length (m).
  gait7: planar two-leg model with HAT (thesis 2.3.1), from --mass and --height.
  fullbody: 3D 35-DOF body in the ADAMS/Android layout (thesis 2.3.2), segments by
       de Leva (1996), from --mass, --height and --sex.
"""


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``model build`` and ``model show``."""
    model = commands.add_parser("model", help="build a URDF model or show one",
                                description="Build a URDF model from anthropometry or show one.")
    sub = model.add_subparsers(dest="model_command", metavar="ACTION", required=True)
    build = sub.add_parser("build", help="generate a URDF from anthropometry",
                           description=BUILD_HELP,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    build.add_argument("kind", choices=("rod", "leg", "gait7", "fullbody"), help="model kind")
    build.add_argument("--mass", type=float, metavar="KG",
                       help=f"body mass in kg, 20-300 (leg; default {DEFAULT_SUBJECT['mass']}) "
                            "or rod mass in kg (default: the thesis rod)")
    build.add_argument("--height", type=float, metavar="M",
                       help=f"standing height in m, 0.5-2.5 (leg; default "
                            f"{DEFAULT_SUBJECT['height']})")
    build.add_argument("--length", type=float, metavar="M", help="rod length in m (rod only)")
    build.add_argument("--sex", choices=("male", "female"), default="male",
                       help="de Leva (1996) column (fullbody only; default male)")
    build.add_argument("--segments", type=Path, metavar="CSV",
                       help="segment parameter table (leg only) instead of regressions")
    build.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.urdf",
                       help="output URDF path")
    build.add_argument("--force", action="store_true", help="overwrite an existing output file")
    build.set_defaults(run=run_build)
    show = sub.add_parser("show", help="print segments, joints and frames of a URDF",
                          description="Print the segment table (mass kg, length m, COM m, "
                                      "inertia kg m^2), joints with limits and frames.")
    show.add_argument("urdf", help="a URDF made by 'predgait model build', 'leg' / 'rod', "
                      "or an OpenSim .osim model")
    show.set_defaults(run=run_show)


def run_build(args: argparse.Namespace) -> int:
    """Generate, validate (by loading it) and write the URDF."""
    from predgait.errors import InputError
    from predgait.models.loading import generate_urdf, model_from_urdf

    check_output_file(args.output, force=args.force,
                      inputs=[args.segments] if args.segments else ())  # before any work
    if args.kind == "rod" and (args.height is not None or args.segments is not None):
        raise InputError("the rod takes --mass and --length, not --height or --segments.")
    if args.kind == "leg" and args.length is not None:
        raise InputError("the leg takes --mass and --height (or --segments), not --length.")
    if args.kind in ("gait7", "fullbody"):
        if args.length is not None or args.segments is not None:
            raise InputError(f"{args.kind} takes --mass and --height, not --length or "
                             "--segments.")
        mass = DEFAULT_SUBJECT["mass"] if args.mass is None else args.mass
        height = DEFAULT_SUBJECT["height"] if args.height is None else args.height
        if args.kind == "gait7":
            from predgait.models.gait7 import build_gait7_urdf

            text = build_gait7_urdf(mass, height)
            model_from_urdf(text, source=str(args.output))
        else:
            from predgait.models.fullbody import build_fullbody_urdf
            from predgait.models.loading3d import model3d_from_urdf

            text = build_fullbody_urdf(mass, height, args.sex)
            model3d_from_urdf(text, source=str(args.output))
        write_text_atomic(text, args.output, force=args.force)
        print(f"wrote {args.output}")
        return 0
    text = generate_urdf(args.kind, mass=args.mass, height=args.height, length=args.length,
                         segments=args.segments)
    model_from_urdf(text, source=str(args.output))
    write_text_atomic(text, args.output, force=args.force,
                      inputs=[args.segments] if args.segments else ())
    print(f"wrote {args.output}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    """Print the model tables (a 3D model: its segments with mass and COM)."""
    from predgait.textfile import read_text

    path = Path(args.urdf)
    if path.suffix.lower() == ".osim":
        return _show_osim(path)
    if path.is_file() and "base=free_flyer" in read_text(path, what="URDF model")[:1000]:
        from predgait.models.loading3d import load_fullbody

        model = load_fullbody(path)
        pm = model.pin_model
        print(f"model: {model.kind} ({model.source}); total mass {model.total_mass():.3f} kg; "
              f"{pm.nv} degrees of freedom (6 at the pelvis)")
        print(f"{'body':<22}{'mass kg':>10}{'COM x, y, z in the body frame (m)':>40}")
        for j in range(1, pm.njoints):
            inertia = pm.inertias[j]
            if inertia.mass > 0:
                com = ", ".join(f"{v:+.3f}" for v in inertia.lever)
                print(f"{pm.names[j]:<22}{inertia.mass:>10.3f}{com:>40}")
        return 0
    from predgait.models.describe import format_model
    from predgait.models.loading import load_model

    print(format_model(load_model(args.urdf)))
    return 0


def _show_osim(path: Path) -> int:
    """An OpenSim model as predgait reads it: bodies, coordinates, muscles, contacts."""
    import math

    from predgait.models.osim import read_osim
    from predgait.models.osim_model import build_model

    osim = read_osim(path)
    built = build_model(osim)
    print(f"model: {osim.name} ({path.name}, OpenSim); total mass {osim.total_mass():.3f} kg; "
          f"{len(osim.coordinates)} coordinates, {len(osim.muscles)} muscles, "
          f"{len(osim.contacts)} contacts; predgait model {built.model.kind}, "
          f"{built.model.nq} coordinates")
    print(f"{'coordinate':<16}{'range':>22}")
    for c in osim.coordinates:
        low, high = c.range
        unit = "m" if c.name.endswith(("_tx", "_ty")) else "deg"
        scale = 1.0 if unit == "m" else 180.0 / math.pi
        print(f"{c.name:<16}{low * scale:>10.1f} .. {high * scale:>6.1f} {unit}")
    print(f"{'muscle':<16}{'F max N':>9}{'l opt m':>9}{'l slack m':>10}")
    for m in osim.muscles:
        print(f"{m.name:<16}{m.max_isometric_force:>9.0f}{m.optimal_fiber_length:>9.3f}"
              f"{m.tendon_slack_length:>10.3f}")
    return 0
