"""The HTML report is self-contained and its 3D viewer runs in a real headless browser.

The browser test uses Debian's Chromium (``apt-get install chromium``); when it is not
installed the test is skipped and says so.
"""

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

from conftest import check_report_page
from predgait.dynamics.inverse_trial import bundled_inverse
from predgait.models.loading import load_model
from predgait.report.html import build_report
from predgait.report.viewer import viewer_data
from predgait.workflows.inverse_io import write_inverse_outputs

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def inverse_report(tmp_path_factory) -> tuple[Path, str]:
    folder = tmp_path_factory.mktemp("report") / "inverse"
    write_inverse_outputs(bundled_inverse("right"), folder)
    page = build_report(folder)
    (folder.parent / "report.html").write_text(page)
    return folder.parent / "report.html", page


def test_viewer_data_follows_the_model():
    leg = load_model("leg")
    q = np.zeros((3, leg.nq))
    q[:, 0] = [0.0, 0.1, 0.2]  # the ankle moves forward 0.1 m per frame
    data = viewer_data(leg, [0.0, 0.1, 0.2], q, grf=(np.tile([0, 0, 700.0], (3, 1)),
                                                     np.zeros((3, 3))))
    lines = data["bodies"][0]["lines"]
    shank = lines[1]  # ankle_center -> knee_center, (frames, 2 points, xyz)
    assert np.allclose(np.array(shank)[:, 0, 0], [0.0, 0.1, 0.2])
    assert np.allclose(np.array(shank)[:, 1, 1], 0.0)  # planar model: Y = 0
    assert np.array(shank)[0, 1, 2] > 0.3  # the knee is above the ankle when standing
    assert data["arrows"][0]["vector"][0] == [0.0, 0.0, 0.7]


def test_report_is_self_contained(inverse_report):
    path, page = inverse_report
    assert not re.search(r"https?://", page), "the page loads something from the network"
    assert "src='file:" not in page and "href='file:" not in page
    assert "class='pg-viewer'" in page and page.count("<script>") == 1
    check_report_page(page, path.parent / "inverse")


@pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (Debian: apt-get "
                                               "install chromium); browser check skipped")
def test_report_runs_in_headless_chromium(inverse_report):
    path, _ = inverse_report
    with tempfile.TemporaryDirectory() as profile:
        result = subprocess.run(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
             "--disable-background-networking", "--disable-component-update",
             "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
             "--enable-logging=stderr", "--v=0", "--virtual-time-budget=3000",
             "--dump-dom", path.as_uri()],
            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    console = [line for line in result.stderr.splitlines() if ":CONSOLE" in line]
    assert not console, console  # the page logs nothing: no error, no warning
    inked = re.findall(r'data-inked-pixels="(\d+)"', result.stdout)
    assert inked and int(inked[0]) > 2000, "the viewer's canvas stayed empty"


def test_contact_grf_is_the_total_force_at_the_loaded_centre():
    from predgait.dynamics.gait7_motion import gait7_model
    from predgait.models.gait7 import CONTACT_FRAMES
    from predgait.report.viewer import contact_grf

    model = gait7_model(72.6, 1.8034)
    q = np.zeros((2, model.nq))  # standing upright
    forces = np.zeros((2, 4, 3))
    forces[0, 0] = [10.0, 0.0, 300.0]   # heel_r
    forces[0, 1] = [0.0, 0.0, 100.0]    # toe_r
    (force, point), (left, left_point) = contact_grf(
        model, q, forces, CONTACT_FRAMES, [("heel_r", "toe_r"), ("heel_l", "toe_l")])
    heel, toe = viewer_positions(model, q[0], ("heel_r", "toe_r"))
    np.testing.assert_allclose(force[0], [10.0, 0.0, 400.0])
    np.testing.assert_allclose(point[0], 0.75 * heel + 0.25 * toe, atol=1e-12)
    assert np.isnan(point[1]).all() and np.isnan(left_point).all()  # unloaded: no arrow


def viewer_positions(model, q, names):
    import pinocchio as pin

    data = model.pin_model.createData()
    pin.framesForwardKinematics(model.pin_model, data, q)
    return [data.oMf[model.frame_id(n)].translation.copy() for n in names]
