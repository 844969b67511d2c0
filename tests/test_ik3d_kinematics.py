"""The IK's marker kinematics as two matrix products (issue 31: batch throughput) against
the per-marker formulas they replaced: the same fits to round-off on the bundled walk.

The full-body IK computes every marker position as one product of the joint placements
and the marker offsets, and every marker Jacobian as one product of the markers' rows
[I | -[p]x] and data.J; before, per marker (p = R_j c + t_j, v_O + omega x p entry by
entry). Summation order differs, so the numbers agree to round-off, not bit for bit; the
Levenberg-Marquardt path (iterations, flags) must be the same.
"""

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.data import read_trc
from predgait.data.bundled import bundled_path
from predgait.dynamics.fullbody_calibration import calibrate_fullbody
from predgait.dynamics.inverse3d_trial import read_marker_map, read_trial
from predgait.kinematics import ik3d

REPO = Path(__file__).resolve().parents[1]


class PerMarker(ik3d._Fitter):
    """The fitter with the per-marker position and Jacobian formulas of before."""

    def points(self, q, *, jacobians=False):
        if jacobians:
            pin.computeJointJacobians(self.pm, self.data, q)
        else:
            pin.forwardKinematics(self.pm, self.data, q)
        placed = np.array([self.data.oMi[j].homogeneous for j in self.joints])[self.of_marker]
        return np.einsum("mij,mj->mi", placed[:, :3, :3], self.offset) + placed[:, :3, 3]

    def jacobian(self, points):
        world = self.data.J
        w, p = world[3:], points[:, :, None]
        jac = np.empty((points.shape[0], 3, world.shape[1]))
        jac[:, 0] = w[1] * p[:, 2] - w[2] * p[:, 1]
        jac[:, 1] = w[2] * p[:, 0] - w[0] * p[:, 2]
        jac[:, 2] = w[0] * p[:, 1] - w[1] * p[:, 0]
        jac += world[:3]
        return jac.reshape(-1, self.pm.nv)


@pytest.fixture(scope="module")
def walk():
    folder = bundled_path("subject01_walk1")
    marker_map = read_marker_map(REPO / "problems" / "markers_fullbody_subject01.toml")
    markers, _ = read_trial([folder / "subject01_walk1.trc", folder / "subject01_walk1_grf.mot"])
    calibration = calibrate_fullbody(marker_map, mass=72.6, height=1.8034, sex="male",
                                     static=read_trc(folder / "subject01_static.trc"),
                                     options=ik3d.IKOptions())
    frames, names = marker_map.fitted()
    xyz = markers.select(list(names)).xyz
    weights = {f: marker_map.weights.get(f, marker_map.weights.get(m, 1.0))
               for f, m in zip(frames, names, strict=True)}
    return calibration, markers.time, xyz, frames, weights


def _fit(walk, xyz):
    calibration, time, _, frames, weights = walk
    return ik3d.solve_ik(calibration.model, time, xyz, frames, weights=weights,
                         locked=calibration.unobserved)


@pytest.mark.parametrize("hidden", [False, True])
def test_matrix_products_fit_as_the_per_marker_formulas(walk, monkeypatch, hidden):
    """subject01's walk (37 markers, 35 DOF), also with markers hidden in some frames:
    joint angles within 1e-6 rad (measured: below 2e-11), the same iterations and flags."""
    xyz = walk[2].copy()
    if hidden:   # the fit over the seen markers only
        xyz[10:40, [3, 20, 31]] = np.nan
        xyz[90:95, 5] = np.nan
    fast = _fit(walk, xyz)
    monkeypatch.setattr(ik3d, "_Fitter", PerMarker)
    before = _fit(walk, xyz)
    np.testing.assert_allclose(fast.q, before.q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(fast.residuals, before.residuals, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(fast.iterations, before.iterations)
    np.testing.assert_array_equal(fast.converged, before.converged)
    np.testing.assert_array_equal(fast.at_limit, before.at_limit)
