"""Start-up: the parser and light commands do not import the heavy numerical packages.

A correctness test, not a timing test: every command registers its options on every run, so a
module-level import of SciPy's signal/stats/optimize/interpolate, matplotlib, CasADi, ADAM,
dask or ezc3d in a command module (or in what it imports) costs every command about a second.
Such packages are imported inside the functions that use them (see docs/DEVELOPING.md).
Speed itself is measured in benchmarks/bench_startup.py.
"""

import json
import subprocess
import sys

import pytest

HEAVY = ("scipy.signal", "scipy.stats", "scipy.optimize", "scipy.interpolate",
         "scipy.integrate", "matplotlib", "casadi", "adam", "dask", "ezc3d")

#: Command lines that must stay light: the parser's help paths and ``model show``.
LIGHT_COMMANDS = (
    ["--help"], ["--version"], ["model", "show", "leg"], ["model", "show", "rod"],
    ["model", "--help"], ["inverse", "--help"], ["simulate", "--help"], ["solve", "--help"],
    ["scenario", "--help"], ["sweep", "--help"], ["report", "--help"], ["demo", "--help"],
)

PROBE = """
import contextlib, io, json, sys
HEAVY = {heavy!r}
def loaded():
    return sorted(m for m in HEAVY if m in sys.modules)
import predgait.cli
found = {{"import predgait.cli": loaded()}}
for argv in {commands!r}:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            status = predgait.cli.main(argv)
        except SystemExit as exc:
            status = exc.code
    found[" ".join(argv)] = [status, loaded()]
print(json.dumps(found))
"""


@pytest.fixture(scope="module")
def probe() -> dict:
    """Heavy modules loaded after each command, in one fresh interpreter (in order)."""
    code = PROBE.format(heavy=HEAVY, commands=LIGHT_COMMANDS)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_importing_the_cli_is_light(probe):
    assert probe["import predgait.cli"] == []


@pytest.mark.parametrize("argv", LIGHT_COMMANDS, ids=" ".join)
def test_light_command_imports_no_heavy_module(probe, argv):
    status, heavy = probe[" ".join(argv)]
    assert status in (0, None), f"predgait {' '.join(argv)} exited with {status}"
    assert heavy == [], (f"predgait {' '.join(argv)} imported {heavy}; import them inside "
                         "the functions that use them")


def test_probe_sees_heavy_imports():
    """The probe itself can fail: spline derivatives do import scipy.interpolate."""
    code = ("import sys; from predgait.data import differentiate; import numpy as np; "
            "t = np.linspace(0, 1, 50); differentiate(np.sin(t), t, method='spline'); "
            "print('scipy.interpolate' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, check=True)
    assert done.stdout.strip() == "True"


def test_leg_inverse_pipeline_imports_no_heavy_module():
    """run_inverse on subject01 (read, joint centres, IK, filters, ID) stays on numpy and
    Pinocchio; SciPy's optimize may come in only when an IK bound binds (not here)."""
    code = ("import sys; from predgait.dynamics.inverse_trial import bundled_options, "
            "run_inverse; run_inverse(bundled_options('right')); "
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True)
    assert done.stdout.strip().splitlines()[-1] == "[]"


@pytest.mark.parametrize("argv", [
    ["inverse", "problems/inverse_subject01.toml"],
    ["inverse", "src/predgait/datasets/subject01_walk1/subject01_walk1.trc", "--grf",
     "src/predgait/datasets/subject01_walk1/subject01_walk1_grf.mot", "--static",
     "src/predgait/datasets/subject01_walk1/subject01_static.trc", "--mass", "72.6",
     "--height", "1.8034", "--model", "fullbody", "--marker-map",
     "problems/markers_fullbody_subject01.toml"],
], ids=["leg", "fullbody"])
def test_inverse_draws_its_plots_without_matplotlib(tmp_path, argv):
    """Both inverse commands write their PNG plots and stick GIF with Pillow
    (report.raster): no Matplotlib, SciPy optimize or CasADi import on those paths."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "out"
    code = ("import sys; from predgait.cli import main; "
            f"status = main({[*argv, '--out', str(out)]!r}); "
            f"print(status, sorted(m for m in {HEAVY!r} if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True, cwd=repo)
    assert done.stdout.strip().splitlines()[-1] == "0 []"
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert len(pngs) >= 2 and (out / "stick.gif").is_file(), pngs


@pytest.mark.parametrize("problem", ["problems/resynthesis.toml", "problems/collapse.toml"])
def test_simulate_draws_its_plots_without_matplotlib(tmp_path, problem):
    """The leg simulations write their PNG charts (angles, deviation, GRF, contributions,
    stick overlays) with Pillow: no Matplotlib or other heavy import on that path."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "out"
    code = ("import sys; from predgait.cli import main; "
            f"status = main(['simulate', {problem!r}, '--out', {str(out)!r}]); "
            f"print(status, sorted(m for m in {HEAVY!r} if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True, cwd=repo)
    assert done.stdout.strip().splitlines()[-1] == "0 []"
    assert {"angles.png", "stick.png", "stick.gif"} <= {p.name for p in out.iterdir()}


def test_adam_is_imported_without_scipy_spatial():
    """Building the ADAM (CasADi) leg model loads no scipy.spatial; the MuJoCo factory's
    deferred Rotation still is SciPy's (same rotation matrix), and ADAM's mass matrix
    equals Pinocchio's CRBA."""
    code = """
import sys
import numpy as np
import pinocchio as pin
from predgait.models.loading import load_model
from predgait.models.symbolic import symbolic_model
leg = load_model("leg")
sym = symbolic_model(leg)
light = "scipy.spatial" not in sys.modules
q = np.array([0.1, 0.9, 0.2, -0.3, 0.4])
m_adam = np.array(sym.mass_matrix(q))
m_pin = pin.crba(leg.pin_model, leg.pin_model.createData(), q)
m_pin = np.triu(m_pin) + np.triu(m_pin, 1).T
from adam.model.mj_factory import mujoco_model
from scipy.spatial.transform import Rotation
same = np.allclose(mujoco_model.R.from_euler("xyz", [0.1, 0.2, 0.3]).as_matrix(),
                   Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_matrix())
print(light, same, np.allclose(m_adam, m_pin, atol=1e-10))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True)
    assert done.stdout.strip().splitlines()[-1] == "True True True"


def test_gait7_simulation_draws_its_plots_without_matplotlib(tmp_path):
    """The gait7 run's grf.png, knee.png and stick.png are Pillow charts (it needs CasADi
    and SciPy for its contact and knee-driven runs, not Matplotlib)."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "out"
    code = ("import sys; from predgait.cli import main; "
            f"status = main(['simulate', 'problems/gait7_contact.toml', '--out', {str(out)!r}]); "
            "print(status, 'matplotlib' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, check=True, cwd=repo)
    assert done.stdout.strip().splitlines()[-1] == "0 False"
    assert {"grf.png", "knee.png", "stick.png"} <= {p.name for p in out.iterdir()}


#: Modules the leg's ``predgait inverse`` (plots included) has no use for: numpy.ma (np.median
#: and np.unique load it), Pillow's BMP/JPEG/PPM plugins (``format=`` loads them), the HTML
#: report and importlib's resource readers (zipfile).
UNUSED_BY_LEG_INVERSE = ("numpy.ma", "PIL.BmpImagePlugin", "PIL.JpegImagePlugin",
                         "PIL.PpmImagePlugin", "predgait.report.html", "importlib.readers")


def test_leg_inverse_loads_only_what_it_uses(tmp_path):
    """`predgait inverse problems/inverse_subject01.toml` with plots imports none of
    UNUSED_BY_LEG_INVERSE (start-up is most of this command's time); the probe sees them
    when they are used (np.median)."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    out = tmp_path / "out"
    argv = ["inverse", "problems/inverse_subject01.toml", "--out", str(out)]
    code = ("import sys; from predgait.cli import main; "
            f"status = main({argv!r}); "
            f"found = sorted(m for m in {UNUSED_BY_LEG_INVERSE!r} if m in sys.modules); "
            "import numpy as np; np.median([1.0, 2.0]); "
            "print(status, found, 'numpy.ma' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=True, cwd=repo)
    assert done.stdout.strip().splitlines()[-1] == "0 [] True"
    assert (out / "stick.gif").is_file() and (out / "moments.png").is_file()
