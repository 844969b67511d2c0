"""Reports name files without their folders, and --anonymise drops the subject's names
(issue 29, item 7): a trial under "Patient Jane Doe (DOB 1970-01-01)/visit 2/"."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from predgait.cli import main
from predgait.report.html import scrub_paths

REPO = Path(__file__).resolve().parents[1]
BUNDLED = REPO / "src" / "predgait" / "datasets" / "subject01_walk1"
VISIT = Path("Patient Jane Doe (DOB 1970-01-01)") / "visit 2"


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """The leg inverse dynamics of subject01, its files under a patient's folder."""
    root = tmp_path_factory.mktemp("lab")
    (root / VISIT).mkdir(parents=True)
    for path in BUNDLED.glob("subject01_*"):
        shutil.copy(path, root / VISIT / path.name.replace("subject01", "jane_doe"))
    problem = (REPO / "problems" / "inverse_subject01.toml").read_text().replace(
        "bundled:subject01_walk1/subject01", f"{VISIT.as_posix()}/jane_doe")
    (root / "inverse.toml").write_text(problem)
    patch = pytest.MonkeyPatch()
    patch.chdir(root)
    try:
        assert main(["inverse", "inverse.toml", "--out", "Jane Doe results", "--no-plots"]) == 0
    finally:
        patch.undo()
    assert "Patient Jane Doe" in (root / "Jane Doe results" / "summary.json").read_text()
    return root / "Jane Doe results"


def _page(result, tmp_path, *extra) -> str:
    page = tmp_path / "page.html"
    assert main(["report", str(result), "-o", str(page), *extra]) == 0
    return page.read_text()


def test_report_shows_file_names_without_their_folders(result, tmp_path):
    page = _page(result, tmp_path)
    for secret in ("Patient", "1970-01-01", "visit 2", str(tmp_path)):
        assert secret not in page, secret
    assert "jane_doe_walk1.trc" in page and "jane_doe_walk1_grf.mot" in page
    assert "without folders" in page


def test_anonymised_report_drops_the_subject_names(result, tmp_path):
    page = _page(result, tmp_path, "--anonymise")
    for secret in ("Patient", "1970-01-01", "visit 2", "jane", "Jane"):
        assert secret not in page, secret
    assert "Anonymised" in page and "Inverse dynamics" in page


@pytest.mark.parametrize(("text", "shown"), [
    ("Patient Jane Doe (DOB 1970-01-01)/visit 2/walk 1.trc", "walk 1.trc"),
    ("trial=a b/c (d)/w.trc; grf=/srv/x y/g.mot; side=right",
     "trial=w.trc; grf=g.mot; side=right"),
    (r"C:\Users\Jane Doe\w.c3d", "w.c3d"),
    ("/home/jane/Patient Jane/run", "run"),
    ("results/Patient Jane/", "(folder)"),
    ("speed in m/s, moment in N m/kg", "speed in m/s, moment in N m/kg"),
    ("bundled:subject01_walk1/subject01_walk1.trc", "subject01_walk1.trc"),
])
def test_scrub_paths(text, shown):
    assert scrub_paths(text) == shown
