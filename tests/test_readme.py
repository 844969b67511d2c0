"""README's set-up commands are the ones CI runs."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_ci_runs_the_readme_test_command():
    readme = REPO.joinpath("README.md").read_text()
    ci_lines = [line for line in REPO.joinpath(".ci/run").read_text().splitlines()
                if line.startswith("python3 -m venv")]
    assert len(ci_lines) == 1
    assert f"\n{ci_lines[0]}\n" in readme
    assert "predgait demo" in readme
