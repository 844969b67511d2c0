"""``predgait demo`` in an empty folder, and ``predgait report`` on its results."""

import subprocess
import sys

import pytest

from predgait.errors import InputError
from predgait.report.html import build_report


def run_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "predgait", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


@pytest.fixture(scope="module")
def demo_folder(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("demo")
    result = run_cli("demo", cwd=cwd)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    return cwd / "predgait-demo"


def test_demo_writes_results_and_a_report(demo_folder):
    assert (demo_folder / "01_inverse_dynamics" / "inverse_dynamics.sto").is_file()
    html = (demo_folder / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 4
    assert "peak_moments_n_m_per_kg" in html and "src=" in html
    assert "file:" not in html  # self-contained: no links to local files


def test_demo_replaces_only_its_own_folder(demo_folder):
    again = run_cli("demo", cwd=demo_folder.parent)
    assert again.returncode == 0, again.stderr
    other = demo_folder.parent / "mine"
    other.mkdir()
    (other / "data.txt").write_text("user data")
    refused = run_cli("demo", "--out", "mine", cwd=demo_folder.parent)
    assert refused.returncode == 2 and "not a previous demo folder" in refused.stderr
    assert (other / "data.txt").read_text() == "user data"


def test_report_command(demo_folder, tmp_path):
    out = tmp_path / "r.html"
    result = run_cli("report", str(demo_folder / "01_inverse_dynamics"), "-o", str(out),
                     cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "ankle_dorsiflexion_moment" in out.read_text()
    with pytest.raises(InputError, match="result folder not found"):
        build_report(tmp_path / "none")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match="no results"):
        build_report(empty)
