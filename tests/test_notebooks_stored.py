"""The notebooks are stored with their outputs, from their current code, and README names them.

Nothing is executed here (CI executes them: ``python -m pytest notebooks``); the stored
outputs are checked against the code that made them through the fingerprint that
``notebooks/regenerate.py`` writes.
"""

import importlib.util
import re
from pathlib import Path

import nbformat
import pytest

REPO = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))


def _regenerate():
    spec = importlib.util.spec_from_file_location("regenerate", REPO / "notebooks" /
                                                  "regenerate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


REGENERATE = _regenerate()


def test_there_are_notebooks():
    assert len(NOTEBOOKS) >= 10


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_stored_outputs_come_from_the_current_code(path):
    notebook = nbformat.read(path, as_version=4)
    stored = notebook.metadata.get("predgait", {}).get("code_sha256")
    assert stored == REGENERATE.code_sha256(notebook), (
        f"{path.name}: stored outputs are not from its current code; run "
        f"'python notebooks/regenerate.py {path.stem}'")
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert [cell.execution_count for cell in code] == list(range(1, len(code) + 1))
    outputs = [out for cell in code for out in cell.outputs]
    assert not [out for out in outputs if out.output_type == "error"]
    assert all(cell.outputs for cell in code if cell.source.strip()), "a cell without output"
    if any(re.search(r"\bplt\.|\.plot\(|imshow|Image\(", cell.source) for cell in code):
        assert any("image/png" in out.get("data", {}) for out in outputs), "no figure stored"


def test_the_fingerprint_changes_with_the_code():
    notebook = nbformat.read(NOTEBOOKS[0], as_version=4)
    before = REGENERATE.code_sha256(notebook)
    next(c for c in notebook.cells if c.cell_type == "code").source += "\n1"
    assert REGENERATE.code_sha256(notebook) != before


def test_readme_names_every_notebook_with_a_line():
    readme = (REPO / "README.md").read_text()
    for path in NOTEBOOKS:
        line = next((x for x in readme.splitlines() if f"`{path.name}`" in x), "")
        assert len(line.split(f"`{path.name}`", 1)[1].strip(" :-—")) > 15, path.name
    assert "python notebooks/regenerate.py" in readme
