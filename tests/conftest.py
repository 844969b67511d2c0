"""Shared fixtures: the real-data folder beside the checkout, and the shipped models."""

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

# Solvers are built in memory in tests (no compiling into the user's cache folder);
# tests/test_solver_cache.py turns the cache on in a temporary folder.
os.environ.setdefault("PREDGAIT_SOLVER_CACHE", "off")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
#: Most test workers ``-n auto`` starts (each builds its own session fixtures and models).
MAX_WORKERS = 4


def pytest_xdist_auto_num_workers(config) -> int:
    """``-n auto``: one worker per core, at most :data:`MAX_WORKERS`."""
    return max(1, min(MAX_WORKERS, len(os.sched_getaffinity(0))))


#: The longest test files, s (sum of their tests' setup and call, full suite on the 2-core
#: machine at load ~5-6 beside other work, issue 30's last item; before the muscle NLP's
#: node-by-node derivatives: this order gave the fastest CI measured, 9 min 49 s, where the
#: order of the times re-measured after it, 1028 worker-s, gave 10 min 23-30 s with one
#: muscle test 10x slower). They run first: xdist's
#: own order (files with the most tests first) started the one-test files last, so that one
#: of these (notebook 10, a whole-body tracking fixture) ran alone at the end while the
#: other worker idled.
LONG_FILES = {
    "tests/test_muscle_scenarios.py": 503, "tests/test_muscle_multistart.py": 367,
    "notebooks/10_muscle_prediction.ipynb": 263,
    "tests/test_fullbody_tracking_walking5.py": 239, "tests/test_passive_swing.py": 160,
    "tests/test_fullbody_tracking_cycle.py": 145, "tests/test_predict_scenarios.py": 141,
    "tests/test_toes_model.py": 121, "notebooks/07_whole_body.ipynb": 87,
    "notebooks/08_predictive_gait.ipynb": 85, "tests/test_predict.py": 66,
    "tests/test_fullbody_tracking.py": 57, "tests/test_demo_report.py": 56,
}


def pytest_collection_modifyitems(config, items) -> None:
    """Files in the order a worker should take them (``--dist loadfile`` with
    ``--no-loadscope-reorder``): :data:`LONG_FILES` longest first, then the other files
    with the most tests first (xdist's own order); a file's tests keep their order."""
    files = [item.nodeid.split("::")[0] for item in items]
    count, first = {}, {}
    for index, name in enumerate(files):
        count[name] = count.get(name, 0) + 1
        first.setdefault(name, index)
    order = {name: (-LONG_FILES.get(name, 0), -count[name], first[name]) for name in count}
    items[:] = [item for _, item in sorted(zip(files, items, strict=True),
                                           key=lambda pair: order[pair[0]])]


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The third-party trials in ../shared/data (CI clones the repo beside shared/)."""
    if not SHARED_DATA.is_dir():
        raise FileNotFoundError(f"{SHARED_DATA} is missing: clone predgait beside shared/.")
    return SHARED_DATA


#: Text that is a Python repr rather than a value: None/True/nan as words, ``Name(...)``,
#: ``array(``, a dict or list printed as text, ``<... object at 0x...>``.
PYTHON_REPR = re.compile(r"^(None|True|False|nan|-?inf)$|^[A-Za-z_][\w.]*\(.*\)$|array\(|"
                         r"^[\[{].*[\]}]$|object at 0x")


def _strings(value):
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for key, item in value.items():
            yield key
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


def check_report_page(page: str, folder: Path) -> None:
    """A report page: no Python None, no folder above the result folder."""
    text = re.sub(r"data:[\w/+]+;base64,[\w+/=]+", "", page)
    assert "None" not in text, "None in the report page"
    for outside in {str(Path(folder).resolve().parent), str(REPO), "/tmp/"}:
        assert outside not in text, f"path {outside} in the report page"


@pytest.fixture(scope="session")
def assert_tidy_result():
    """A check of a result folder's summary file and of the report page of that folder.

    The summary holds JSON values only, no string that is a Python repr; the page has a
    headline with numbers and a sentence, no ``None`` and no path outside the folder.
    """
    from predgait.report.headline import headline
    from predgait.report.html import build_report

    def check(path: Path) -> dict:
        text = Path(path).read_text()
        data = json.loads(text)
        assert "NaN" not in text and "Infinity" not in text  # json.loads accepts both
        bad = [s for s in _strings(data) if PYTHON_REPR.search(s.strip())]
        assert not bad, f"{path}: Python reprs in JSON: {bad[:5]}"
        folder = Path(path).parent
        head = headline(folder)
        assert head is not None and len(head.numbers) >= 2 and head.sentence, head
        check_report_page(build_report(folder), folder)
        return data
    return check


def _immutable(paths, on: bool) -> None:
    subprocess.run(["chattr", "+i" if on else "-i", *map(str, paths)], check=True,
                   capture_output=True)


@pytest.fixture
def read_only():
    """Make paths unwritable, undone after: ``chattr +i`` as root (for whom permission
    bits do not stop a write; needs chattr and a file system that has it, e.g. ext4),
    ``chmod a-w`` as another user. Skips, saying why, when it cannot."""
    made = []

    def make(*paths):
        if os.geteuid() == 0:
            if shutil.which("chattr") is None:
                pytest.skip("root without chattr: cannot make a folder read-only for root")
            try:
                _immutable(paths, True)
            except subprocess.CalledProcessError:
                pytest.skip("chattr +i not supported on this file system")
        else:
            for path in paths:
                path.chmod(path.stat().st_mode & ~0o222)
        made.extend(paths)

    yield make
    if made and os.geteuid() == 0:
        _immutable(made, False)
    for path in made:
        path.chmod(path.stat().st_mode | 0o200)


@pytest.fixture
def assert_leg_knee_starts_on_measured(tmp_path):
    """Check a leg run's states.sto in its stated unit (rad) against the measured knee.

    The measured knee: the leg inverse of subject01 through the CLI (kinematics.sto, its
    stated rad; knee flexion = -q_knee). Over the first 30 ms (~5 deg of knee motion) the
    run moves with it to a tenth of a degree; its level may sit a few degrees off (a
    scenario or resynthesis file has its own inverse problem).
    """
    import numpy as np

    from predgait.cli import main
    from predgait.data import read_storage

    def check(path: Path) -> None:
        states = read_storage(path)
        assert states.header["units"].startswith("m, rad") and not states.in_degrees
        out = tmp_path / "measured_inverse"
        problem = Path(__file__).resolve().parents[1] / "problems" / "inverse_subject01.toml"
        assert main(["inverse", str(problem), "--no-plots", "--out", str(out)]) == 0
        measured = read_storage(out / "kinematics.sto")
        assert measured.header["units"].startswith("SI (rad") and not measured.in_degrees
        early = states.time <= states.time[0] + 0.03
        knee = np.degrees(np.interp(states.time[early], measured.time,
                                    measured.column("knee_flexion")))
        simulated = np.degrees(-states.column("knee")[early])
        assert np.max(np.abs(simulated - knee)) < 8.0
        assert np.max(np.abs(np.diff(simulated) - np.diff(knee))) < 0.1
        assert np.ptp(knee) > 3.0

    return check


@pytest.fixture
def count_leg_calibrations():
    """Patch the leg's static calibration to record the side of every call and empty the
    batch workers' kept calibrations: returns a function of ``monkeypatch`` giving that list."""

    def patch(monkeypatch) -> list[str]:
        from predgait.dynamics import leg_static
        from predgait.workflows import batch_warm

        calls, real = [], leg_static.leg_static

        def counted(options, turn):
            calls.append(str(options.side))
            return real(options, turn)

        monkeypatch.setattr(leg_static, "leg_static", counted)
        monkeypatch.setattr(batch_warm, "_kept", type(batch_warm._kept)())
        return calls

    return patch


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    """The compiled-function cache on, in a fresh folder for the module (compiled once;
    the passive swing fits then run ~40x faster than in CasADi's virtual machine)."""
    from predgait import function_cache

    with pytest.MonkeyPatch.context() as patch:
        if function_cache.compiler() is not None:
            patch.setenv(function_cache.SWITCH, "on")
            patch.setenv(function_cache.FOLDER, str(tmp_path_factory.mktemp("cache")))
            patch.setenv(function_cache.WHEN, "now")
        yield
