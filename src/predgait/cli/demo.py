"""``predgait demo``: the main job on the bundled real trial, with no argument."""

from __future__ import annotations

import argparse

from predgait.models.describe import format_model
from predgait.models.loading import load_model


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``demo``."""
    demo = commands.add_parser(
        "demo", help="run the pipeline on the bundled trial (no argument needed)",
        description="Build the leg model of the bundled subject (OpenSim subject01, "
                    "72.6 kg, 1.80 m) and print its segment table.")
    demo.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Build the bundled subject's leg and print it."""
    print(format_model(load_model("leg")))
    return 0
