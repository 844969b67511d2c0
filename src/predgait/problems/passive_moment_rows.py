"""The inverse-dynamics moments of the quiet phases as a second residual of the angle fit.

The fit to the swing angles (:mod:`predgait.problems.passive_swing`) sees the passive
moment only through the motion it causes; the moment decomposition
(:mod:`predgait.problems.decomposition`) sees it directly but through twice-differentiated
markers. Both measure the same tissue, so kind ``passive_knee_ankle`` fits them together:
to the angle residuals it adds, for every quiet sample in the windows and each joint,

    r_m = sqrt(w) (tau_passive(theta, theta'; p) - tau_ID) / sigma_m,

w = 1 / m (m samples per correlation time, as for the angles) and sigma_m the joint's
moment residual SD of the previous pass (its measured noise; 1 N m to start). The rows
enter the Gauss-Newton fit beside the priors (:class:`WithMoments`), so the Fisher
information the fit reports holds both residuals. theta, theta' are the measured clinical
angles and rates (anatomical knee flexion, as in the decomposition).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from predgait.problems.gait_samples import GaitSamples
from predgait.problems.gauss_newton import LeastSquares
from predgait.problems.passive_model import PassiveModel

#: Relative step of the central differences in z (parameters scaled to their bounds).
STEP = 1e-6


@dataclass(frozen=True, eq=False)
class MomentRows:
    """Moment residual rows of the quiet samples.

    Attributes:
        model: The passive model.
        angles, rates, moments: joint -> (k_j,) clinical angle (rad), rate (rad/s) and
            inverse-dynamics moment (N m) of the joint's quiet samples.
        weight: w = 1 / m.
        sigma: joint -> moment residual SD, N m.
    """

    model: PassiveModel
    angles: dict
    rates: dict
    moments: dict
    weight: float
    sigma: dict = field(default_factory=dict)

    @classmethod
    def of(cls, samples: GaitSamples, quiet: np.ndarray, model: PassiveModel) -> MomentRows:
        """The rows of the samples where ``quiet`` (n,) holds and every value is finite."""
        keep = {j: quiet & np.isfinite(samples.angles[j]) & np.isfinite(samples.rates[j])
                & np.isfinite(samples.moments[j]) for j in model.joints}
        return cls(model, {j: samples.angles[j][k] for j, k in keep.items()},
                   {j: samples.rates[j][k] for j, k in keep.items()},
                   {j: samples.moments[j][k] for j, k in keep.items()},
                   1.0 / samples.samples_per_correlation,
                   dict.fromkeys(model.joints, 1.0))

    def values(self, zf) -> dict:
        """Every parameter's value at fitted parameters ``zf`` scaled to their bounds."""
        values = self.model.values()
        values.update({p.key: p.lower + (p.upper - p.lower) * float(zf[i])
                       for i, p in enumerate(self.model.fitted)})
        return values

    def residuals(self, values) -> dict:
        """Per joint: (k_j,) tau_passive - tau_ID, N m."""
        return {j: np.asarray(self.model.passive_joint(j, values).moment(
            self.angles[j], self.rates[j])) - self.moments[j] for j in self.model.joints}

    def _rows(self, zf) -> np.ndarray:
        res = self.residuals(self.values(zf))
        return np.concatenate([np.sqrt(self.weight) * res[j] / self.sigma[j]
                               for j in self.model.joints])

    def __call__(self, zf) -> tuple[np.ndarray, np.ndarray]:
        """(r (k,), J (k, f)) at ``zf``; J by central differences."""
        zf = np.asarray(zf, dtype=float)
        r = self._rows(zf)
        jac = np.empty((r.size, zf.size))
        for i in range(zf.size):
            dz = np.zeros(zf.size)
            dz[i] = STEP
            jac[:, i] = (self._rows(zf + dz) - self._rows(zf - dz)) / (2 * STEP)
        return r, jac

    def with_noise_of(self, zf) -> MomentRows:
        """The rows with sigma_m = the residual SD at ``zf``, at least 1e-3 N m.

        The SD in effectively independent samples, less the joint's fitted parameters.
        """
        res = self.residuals(self.values(zf))
        sigma = {}
        for j in self.model.joints:
            n_fit = sum(p.joint == j for p in self.model.fitted)
            dof = max(res[j].size * self.weight - n_fit, 1.0)
            sigma[j] = max(float(np.sqrt(self.weight * np.sum(res[j] ** 2) / dof)), 1e-3)
        return replace(self, sigma=sigma)


@dataclass(frozen=True, eq=False)
class WithMoments(LeastSquares):
    """A fit's :class:`LeastSquares` problem with the moment rows beside its priors."""

    rows: MomentRows | None = None

    def prior_rows(self, z) -> tuple[np.ndarray, np.ndarray]:
        """The priors' rows, then the moment rows (zero in the initial-state columns)."""
        r, jac = super().prior_rows(z)
        f = len(self.model.fitted)
        rm, jm = self.rows(np.asarray(z)[:f])
        jm = np.hstack([jm, np.zeros((rm.size, np.size(z) - f))])
        return np.concatenate([r, rm]), np.vstack([jac, jm])


def with_moments(problem: LeastSquares, rows: MomentRows) -> WithMoments:
    """``problem`` (sharing its evaluations) with the moment rows."""
    return WithMoments(problem.model, problem.compute, problem._last, rows)
