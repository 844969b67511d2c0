"""``predgait report DIR -o report.html``: one self-contained HTML page of a result folder."""

from __future__ import annotations

import argparse
from pathlib import Path

from predgait.models.urdf import check_output_file, write_text_atomic

#: The names ``-o`` accepts: the report is HTML.
SUFFIXES = (".html", ".htm")


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``report``."""
    report = commands.add_parser(
        "report", help="write a self-contained HTML report of a result folder",
        description="Write one HTML page (embedded plots, tables of summaries and "
                    "per-column statistics of STO/CSV results) for any predgait --out folder.")
    report.add_argument("folder", type=Path, help="result folder (the --out of a command)")
    report.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.html")
    report.add_argument("--force", action="store_true", help="overwrite an existing report")
    report.add_argument("--anonymise", action="store_true",
                        help="also leave out the trial and input file names and the result "
                             "folder's name (files are always named without their folders)")
    report.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Build and write the report."""
    from predgait.report.html import build_report  # not on every command's start-up path

    check_output_file(args.output, force=args.force, inputs=[args.folder])  # before work
    if args.output.suffix.lower() not in SUFFIXES:
        from predgait.errors import InputError

        raise InputError(f"-o {args.output}: predgait report writes one HTML page; name it "
                         f"{args.output.with_suffix('.html').name} (a PDF: print the page "
                         "from a browser).")
    write_text_atomic(build_report(args.folder, anonymise=args.anonymise), args.output,
                      force=args.force, inputs=[args.folder])
    print(f"wrote {args.output}")
    return 0
