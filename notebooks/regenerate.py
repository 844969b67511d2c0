"""Execute the notebooks and store them with their outputs (text and figures).

Run from the repository root, after ``pip install ".[test]"`` (nbclient, ipykernel)::

    python notebooks/regenerate.py                  # every notebook, one at a time
    python notebooks/regenerate.py 04_knee_fit      # only those named (with or without .ipynb)

Each notebook is executed top to bottom in its own folder, as ``python -m pytest notebooks``
(nbmake) does, and written back whole (a temporary file renamed over it) only when every
cell ran without an error. The notebook's metadata then holds ``predgait.code_sha256``: the
SHA-256 of its code cells' sources; ``tests/test_notebooks_stored.py`` checks that the stored
outputs come from the code as it is now (and that every code cell was run, in order, with
no error), without executing anything. Editing a code cell means running this again.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: Seconds a cell may run (the muscle-driven and predictive notebooks take minutes).
TIMEOUT = 3600


def code_sha256(notebook) -> str:
    """SHA-256 of the notebook's code cells' sources, in order (a cell ends with NUL)."""
    digest = hashlib.sha256()
    for cell in notebook.cells:
        if cell.cell_type == "code":
            digest.update(cell.source.encode("utf-8") + b"\0")
    return digest.hexdigest()


def regenerate(path: Path) -> float:
    """Execute ``path`` and store it with its outputs; returns the seconds it took."""
    import nbformat
    from nbclient import NotebookClient

    notebook = nbformat.read(path, as_version=4)
    started = time.perf_counter()
    NotebookClient(notebook, timeout=TIMEOUT, kernel_name="python3",
                   resources={"metadata": {"path": str(path.parent)}}).execute()
    notebook.metadata["predgait"] = {"code_sha256": code_sha256(notebook)}
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as file:
            nbformat.write(notebook, file)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    return time.perf_counter() - started


def main(argv: list[str] | None = None) -> int:
    """Regenerate the named notebooks (all by default), one at a time."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="notebook names (default: all)")
    args = parser.parse_args(argv)
    paths = sorted(HERE.glob("*.ipynb"))
    if args.names:
        wanted = {name.removesuffix(".ipynb") for name in args.names}
        unknown = wanted - {p.stem for p in paths}
        if unknown:
            print(f"regenerate: error: no notebook {sorted(unknown)} in {HERE}", file=sys.stderr)
            return 2
        paths = [p for p in paths if p.stem in wanted]
    # The kernel draws figures inline (stored as PNG outputs) only without a backend set:
    # MPLBACKEND=Agg (as CI sets for the tests) would leave plt.show() drawing nothing.
    os.environ.pop("MPLBACKEND", None)
    for path in paths:
        print(f"{path.name}: {regenerate(path):.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
