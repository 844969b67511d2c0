"""``predgait demo`` in an empty folder, and ``predgait report`` on its results."""

import json
import subprocess
import sys
from html import escape

import pytest

from conftest import check_report_page
from predgait.cli.demo import DEFAULT_OUT, MARKER
from predgait.errors import InputError
from predgait.report.html import build_report
from predgait.report.plot_labels import SIGN_CONVENTION, gif_caption, label_problems, read_labels


def run_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "predgait", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


@pytest.fixture(scope="module")
def demo_folder(tmp_path_factory):
    """One demo run, over a previous demo's folder (one with the demo's marker file, as
    every demo writes: test_demo_replaces_only_its_own_folder), so the one run checks the
    replacement too; a stale file of the previous demo must be gone after it."""
    cwd = tmp_path_factory.mktemp("demo")
    previous = cwd / DEFAULT_OUT
    previous.mkdir()
    (previous / MARKER).write_text("written by an earlier predgait demo\n")
    (previous / "stale.txt").write_text("from the previous demo")
    result = run_cli("demo", cwd=cwd)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    (cwd / "demo_stdout.txt").write_text(result.stdout)
    return previous


def test_demo_prints_and_headlines_the_warnings_of_its_results(demo_folder):
    """The stiffer-knee scenario's feedback (peak ~480 N m at the ankle, the subject's own
    peak moment 124 N m: issue 30) is a warning on the console and in its headline."""
    from predgait.report.headline import headline

    stdout = (demo_folder.parent / "demo_stdout.txt").read_text()
    scenario = demo_folder / "05_scenario_stiff_knee"
    summary = json.loads((scenario / "summary.json").read_text())
    assert summary["status"] == "completed with warnings"
    assert any(w.startswith("peak |ankle feedback torque|") for w in summary["warnings"])
    for folder in sorted(demo_folder.glob("0*_*")):
        head = headline(folder)
        for line in head.warnings:
            assert f"warning: {line}" in stdout
    assert headline(scenario).warnings == tuple(summary["warnings"])


def test_demo_writes_results_and_a_report(demo_folder, assert_tidy_result):
    assert (demo_folder / "01_inverse_dynamics" / "inverse_dynamics.sto").is_file()
    html = (demo_folder / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 4
    assert "file:" not in html  # self-contained: no links to local files
    check_report_page(html, demo_folder)
    for path in sorted(demo_folder.glob("0*/*.json")):
        assert_tidy_result(path)
    # A walk-through in order, each step with its headline and a sentence from its numbers.
    steps = [html.index(f"<h2>{n}. ") for n in range(1, 6)]
    assert steps == sorted(steps) and html.count("class='interpretation'") == 5
    resynthesis = json.loads((demo_folder / "02_resynthesis" / "summary.json").read_text())
    fall = f"falls at {resynthesis['time_to_fall_s']:.3f} s"
    assert fall in html[steps[1]:steps[2]]
    assert "peak ankle plantarflexor moment" in html and "N m/kg" in html
    assert html.index("class='headline'", steps[0]) < html.index("<img", steps[0]) < html.index(
        "<details>", steps[0])


def test_demo_replaces_only_its_own_folder(demo_folder):
    """The fixture's run replaced a previous demo folder (marker file, stale file gone) and
    marked its own, so a next demo replaces it; a folder without the marker is refused."""
    assert (demo_folder / MARKER).read_text().startswith("written by predgait demo")
    assert not (demo_folder / "stale.txt").exists()
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


def test_every_report_plot_states_its_x_axis_and_signs(demo_folder):
    """One convention at the top; each plot names its x axis and shows clinical signs."""
    import html as html_lib

    page = (demo_folder / "report.html").read_text()
    assert page.count(html_lib.escape(SIGN_CONVENTION)) == 1
    assert page.index("class='convention'") < page.index("<h2>")
    pngs = sorted(demo_folder.rglob("*.png"))
    assert len(pngs) >= 15
    problems = {str(p.relative_to(demo_folder)): label_problems(*read_labels(p)) for p in pngs}
    assert not any(problems.values()), problems
    assert page.count("(x: ") == len(pngs)
    assert "(x: time from heel strike (s))" in page and "(x: % gait cycle)" in page
    # Re-synthesis: knee flexion positive in mid-swing (about 60 deg), as everywhere else.
    x_axis, labels = read_labels(demo_folder / "02_resynthesis" / "angles.png")
    assert "knee flexion (deg)" in labels and x_axis == ["time from heel strike (s)"]
    # GIF captions say what is drawn: grey only where a measured figure is drawn behind.
    captions = {p.parent.name: gif_caption(p) for p in demo_folder.rglob("stick.gif")}
    assert "measured in grey" in captions["02_resynthesis"]
    assert "measured in grey" not in captions["01_inverse_dynamics"]
    assert all(c in page for c in captions.values())


def test_demo_headlines_the_passive_answer_not_the_ill_posed_knee_fit(demo_folder):
    """Issue 30: step 3 is the passive knee and ankle of issue 28's front, and its headline
    says per joint what the trial can or cannot identify (subject01: not identifiable)."""
    html = (demo_folder / "report.html").read_text()
    assert not (demo_folder / "03_knee_fit").exists() and "knee_fit" not in html
    solution = json.loads((demo_folder / "03_passive_knee_ankle" / "solution.json").read_text())
    step3 = html[html.index("<h2>3. "):html.index("<h2>4. ")]
    assert "Passive knee and ankle" in step3
    for joint, answer in solution["answers"].items():
        assert escape(f"{joint}: {answer['text']}") in step3
