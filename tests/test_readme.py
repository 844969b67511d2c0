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


# --- README "Usage" as a user runs it --------------------------------------------------
#
# Every bash line of the Usage section is run in order, in a temporary copy of the
# repository with ../shared beside it, as a new user would after the set-up command (the
# environment activated as the README says). Commands that take minutes (whole-body
# pipelines, optimisation, scenarios and sweeps, notebooks, benchmarks) are run only with
# PREDGAIT_README_FULL=1, to keep CI within its time budget; without it their file
# arguments and output folders are still checked to exist at that point of the sequence.

import os  # noqa: E402
import re  # noqa: E402
import shlex  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import pytest  # noqa: E402

FULL = os.environ.get("PREDGAIT_README_FULL") == "1"
#: Commands (by a fragment) that take minutes: run only with PREDGAIT_README_FULL=1.
SLOW = ("--model fullbody", "gait7_contact.toml", "fullbody_resynthesis.toml",
        "resynthesis.toml", "predgait scenario", "predgait sweep", "predgait solve",
        "pytest notebooks", "notebooks/regenerate.py", "benchmarks/")
#: Commands that change the environment rather than use predgait: never run here.
NOT_RUN = {"pip install": "installs packages (CI installs '.[test]', which has dask)"}


def usage_commands(readme: str) -> list[str]:
    """The bash lines of README's Usage section, continuation lines joined."""
    usage = readme.split("\n## Usage", 1)[1].split("\n## ", 1)[0]
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", usage, re.S):
        lines += block.replace("\\\n", " ").splitlines()
    return [line.strip() for line in lines if line.strip()]


def _paths(command: str, variables: dict[str, str]) -> tuple[list[str], list[str]]:
    """Input paths and output paths named by a predgait command."""
    words = shlex.split(command, comments=True)
    words = [re.sub(r"\$(\w+)", lambda m: variables.get(m.group(1), m.group(0)), w)
             for w in words]
    inputs, outputs = [], []
    for i, word in enumerate(words):
        if words[i - 1] in ("--out", "-o"):
            outputs.append(word)
        elif "/" in word and not word.startswith(("-", "tcp:", "hip=")):
            inputs.append(word)
    return inputs, outputs


@pytest.fixture
def fresh_clone(tmp_path) -> Path:
    """A copy of the repository's tracked inputs with ../shared and the environment."""
    clone = tmp_path / "predgait"
    clone.mkdir()
    for name in ("problems", "urdf", "benchmarks", "notebooks"):
        shutil.copytree(REPO / name, clone / name, symlinks=True,
                        ignore=shutil.ignore_patterns("__pycache__", ".ipynb_checkpoints"))
    for name in ("README.md", "pyproject.toml"):
        shutil.copy(REPO / name, clone / name)
    (tmp_path / "shared").symlink_to(REPO.parent / "shared")
    (clone / ".venv").symlink_to(Path(sys.prefix))
    return clone


def test_readme_usage_runs_as_written(fresh_clone):
    commands = usage_commands(REPO.joinpath("README.md").read_text())
    assert commands[0] == ". .venv/bin/activate" and commands[1] == "mkdir -p out"
    prefix = ". .venv/bin/activate"
    variables: dict[str, str] = {}
    timings = []
    for command in commands[1:]:
        assignment = re.fullmatch(r"(\w+)=(\S+)", command)
        if assignment:
            variables[assignment.group(1)] = assignment.group(2)
            prefix += f" && {command}"
            continue
        if any(fragment in command for fragment in NOT_RUN):
            continue
        if not FULL and ("--scheduler" in command or command.startswith(("dask ", "kill "))):
            continue  # the README's own Dask scheduler, workers and sweep: the full run
        if not FULL and any(fragment in command for fragment in SLOW):
            inputs, outputs = _paths(command, variables)
            for path in inputs:
                assert (fresh_clone / path).exists(), f"{command}: {path} does not exist"
            for path in outputs:
                assert (fresh_clone / path).parent.is_dir(), f"{command}: no folder for {path}"
                assert not (fresh_clone / path).exists(), f"{command}: {path} already written"
            continue
        started = time.perf_counter()
        result = subprocess.run(["bash", "-c", f"{prefix} && {command}"], cwd=fresh_clone,
                                capture_output=True, text=True, timeout=1800,
                                env={**os.environ, "MPLBACKEND": "Agg"})
        timings.append((time.perf_counter() - started, command))
        assert result.returncode == 0, f"{command}\n{result.stdout[-1500:]}{result.stderr[-3000:]}"
        assert "Traceback" not in result.stderr, result.stderr[-3000:]
        for path in _paths(command, variables)[1]:
            assert (fresh_clone / path).exists(), f"{command} did not write {path}"
    for seconds, command in sorted(timings, reverse=True)[:5]:
        print(f"{seconds:7.1f} s  {command[:90]}")


# --- README says where each Usage input comes from (issue 31, item 6) --------------------
SHARED = REPO.parent / "shared" / "data"


def _shared_inputs(command: str, variables: dict[str, str]) -> list[Path]:
    """Files under ../shared/data a Usage command reads: named on its line or in the
    problem file it runs (string values with a path into shared/data, relative to it)."""
    found = []
    for word in _paths(command, variables)[0]:
        path = REPO / word
        if "shared/data" in word:
            found.append(path.resolve())
        elif path.suffix == ".toml" and path.is_file():
            found += [(path.parent / m).resolve() for m in
                      re.findall(r'"([^"]*shared/data[^"]*)"', path.read_text())]
    return found


def _bundled_copy(path: Path) -> Path | None:
    """The file shipped in the package with the same bytes, if any."""
    datasets = REPO / "src" / "predgait" / "datasets"
    for shipped in datasets.rglob(path.name):
        if shipped.read_bytes() == path.read_bytes():
            return shipped
    return None


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data not available")
def test_every_usage_input_is_shipped_or_in_shared_data_and_readme_says_which():
    readme = REPO.joinpath("README.md").read_text()
    data = readme.split("\n## Data", 1)[1].split("\n## ", 1)[0]
    variables: dict[str, str] = {}
    not_shipped = set()
    for command in usage_commands(readme):
        assignment = re.fullmatch(r"(\w+)=(\S+)", command)
        if assignment:
            variables[assignment.group(1)] = assignment.group(2)
            continue
        for path in _shared_inputs(command, variables):
            assert path.is_relative_to(SHARED.resolve()) and path.is_file(), (command, path)
            if _bundled_copy(path) is None:
                not_shipped.add(path.name)
        for name in re.findall(r'"bundled:([\w./-]+/[\w.-]+)"', " ".join(
                (REPO / w).read_text() for w in _paths(command, variables)[0]
                if w.endswith(".toml") and (REPO / w).is_file())):
            assert (REPO / "src" / "predgait" / "datasets" / name).is_file(), name
    assert not_shipped == {"walking5.c3d"}   # the one trial the package does not ship
    for name in not_shipped:
        assert f"`{name}`" in data and "not shipped" in data
    assert "problems/inverse_subject01_left.toml" in data
    for folder in (REPO / "src" / "predgait" / "datasets").iterdir():
        if folder.is_dir() and not folder.name.startswith("__"):
            text = (folder / "README.md").read_text()
            assert "Source" in text and "License" in text, folder.name
