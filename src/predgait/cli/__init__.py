"""The ``predgait`` command line: one module per command, each with ``register``.

Every command reports user errors (:class:`predgait.errors.PredgaitError`) as one line
``predgait: error: ...`` on stderr and exits with status 2; no traceback. Interrupted
runs leave no output and exit 130 (Ctrl-C) or 143 (SIGTERM).
"""

from __future__ import annotations

import argparse
import atexit
import gc
import logging
import signal
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

from predgait import __version__
from predgait.errors import PredgaitError

#: Command modules, in the order they appear in ``predgait --help``.
COMMAND_MODULES = ("demo", "model", "inverse", "simulate", "solve", "scenario", "sweep",
                   "report", "batch")

#: At exit the interpreter's last garbage collections skip the objects a command leaves
#: (the modules it imported: Dask's, NumPy's, ...); the process ends 0.1 s sooner after a
#: batch. Its files are closed by then (each written whole, in ``with`` blocks).
atexit.register(gc.freeze)

DESCRIPTION = """\
predgait: forward dynamic modelling of human walking.

Units are SI throughout (m, kg, s, rad, N, N m) unless an option says otherwise.
Lab frame: X forward, Y lateral (left), Z up; planar models turn about +Y.
Clinical angles: hip flexion, knee flexion and ankle dorsiflexion are positive; a
joint moment is positive when it acts toward the positive angle.
"""


def add_output_options(command: argparse.ArgumentParser, *, overrides: str | None = None
                       ) -> None:
    """--out DIR and --force (and --set KEY=VALUE when ``overrides`` gives an example)."""
    command.add_argument("--out", type=Path, required=True, metavar="DIR", help="result folder")
    if overrides:
        command.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                             help=f"override a key of the file, e.g. --set {overrides} "
                                  "(repeatable)")
    command.add_argument("--force", action="store_true", help="replace an existing --out folder")
    command.add_argument("--no-plots", action="store_true",
                         help="write no PNG/GIF plots (batch use; numbers and tables only)")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every available command registered."""
    import importlib

    parser = argparse.ArgumentParser(
        prog="predgait", description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"predgait {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"predgait.cli.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"predgait.cli.{name}":
                continue
            raise
        module.register(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``predgait`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(message)s")
    if not getattr(args, "run", None):
        parser.print_help()
        return 2
    previous = _interrupt_on_sigterm()
    try:
        from predgait.report.figures import plots_off

        with plots_off(getattr(args, "no_plots", False)), \
                warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")
            status = int(args.run(args) or 0)
        for warning in caught:  # shown only when the command did not fail
            warnings.showwarning(warning.message, warning.category, warning.filename,
                                 warning.lineno)
        return status
    except PredgaitError as exc:  # its warnings (e.g. numpy on bad numbers) are dropped
        print(f"predgait: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. piped into head
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:
        print("predgait: interrupted; no output was completed.", file=sys.stderr)
        return 130
    except Terminated:
        print("predgait: terminated; no output was completed.", file=sys.stderr)
        return 128 + signal.SIGTERM
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        output = sys.modules.get("predgait.workflows.output")
        if output is not None:  # the --out claims of this run (a failed run included)
            output.release_claims()


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so staging folders are removed on the way out.

    Not a KeyboardInterrupt: CPython (3.11) remembers a KeyboardInterrupt that leaves an
    ``exec`` of a string (dataclasses and namedtuples are built that way while modules are
    imported) and, under ``python -m``, ends the process by SIGINT after ``main`` returned,
    even though the exception was handled.
    """


def _raise_terminated(signum, frame):
    raise Terminated


def _interrupt_on_sigterm():
    """Turn SIGTERM into :class:`Terminated`, so staging folders are removed on the way out.

    Returns the previous handler (None when not in the main thread, where Python cannot
    install one).
    """
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_terminated)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
