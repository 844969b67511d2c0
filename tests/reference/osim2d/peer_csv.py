"""The CSV writer of the OpenSim reference generators in this folder (peer scripts only)."""

import csv
import os
from pathlib import Path


def write_table(path: Path, header: list[str], rows: list[list], *, digits: int = 12) -> None:
    """Write ``rows`` under ``header`` whole (temporary file, then rename), numbers to
    ``digits`` significant digits (-0 written as 0), strings as they are."""
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(header)
        for row in rows:
            writer.writerow([v if isinstance(v, str) else format(float(v) + 0.0, f".{digits}g")
                             for v in row])
    os.replace(tmp, path)
