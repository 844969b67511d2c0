"""A synthetic walk with a known passive knee and ankle, for the identification tests.

Forward simulation (Pinocchio, RK4 at 2 ms, independent of the fitting code) of the
planar leg of the bundled subject01 trial, free in the plane, around a periodic version
of its measured motion (Fourier series of the first gait cycle; cycle lengths +-3 %):
a smooth synthetic ground reaction in stance (0-60 %) at a COP rolling from heel to toe;
a hip load (the load predgait's inverse dynamics solves for) = the measured motion's plus
PD tracking of the thigh pose; and at ankle and knee hand-written passive moments
(linear spring-damper, thesis eqs. 3.3.1-3.3.2, and the Anderson 1999 stops as in
Falisse et al. 2019) plus an active torque: feedforward and PD tracking of the measured
motion, switched off over 66-70 % of the cycle and back on over 97-100 % (zero in
70-97 %: the shank and foot swing passively under the thigh). The simulated motion
becomes markers (joint centres, heel, toe; 1 mm noise, 100 Hz) and the ground reaction a
1000 Hz plate (1 % noise): a user's files for ``predgait inverse``. Noise-free, the
inverse dynamics of the simulated motion equals the applied torques to 1e-11 N m.
"""

import numpy as np
import pinocchio as pin

from predgait.dynamics.inverse_options import InverseOptions
from predgait.dynamics.inverse_trial import bundled_inverse
from test_inverse_synthetic import frame_positions, write_grf_mot, write_markers_csv

TRUTH = {"knee.k": 10.0, "knee.c": 0.5, "knee.theta0": 0.6,
         "ankle.k": 20.0, "ankle.c": 0.5, "ankle.theta0": 0.05}
HARMONICS = 10
STANCE = 0.6
MARKER_RATE, PLATE_RATE, STEP = 100.0, 1000.0, 2e-3
#: PD of the active tracking, (ankle, knee): kp N m/rad, kd N m s/rad.
GAINS = (np.array([600.0, 1000.0]), np.array([3.0, 20.0]))
#: PD of the hip load on the thigh pose (x, z in N/m, N s/m; pitch in N m/rad, N m s/rad).
HIP_GAINS = (np.array([2e4, 2e4, 2000.0]), np.array([600.0, 600.0, 80.0]))


def passive_clinical(knee, knee_rate, ankle, ankle_rate, truth=TRUTH):
    """Clinical passive moments (N m) of knee flexion and ankle dorsiflexion, by hand."""
    knee_m = (-truth["knee.k"] * (knee - truth["knee.theta0"]) - truth["knee.c"] * knee_rate
              + 0.0738 * np.exp(-33.94 * knee) - 11.03 * np.exp(-11.33 * (2.40 - knee)))
    ankle_m = (-truth["ankle.k"] * (ankle - truth["ankle.theta0"])
               - truth["ankle.c"] * ankle_rate + 0.18 * np.exp(-12.12 * (ankle + 0.74))
               - 2.03 * np.exp(-38.11 * (0.52 - ankle)))
    return knee_m, ankle_m


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def active_gate(phase):
    """1 while the muscles act, 0 in the quiet part of swing, 70-97 % (phase in [0, 1))."""
    return 1 - _smoothstep((phase - 0.66) / 0.04) + _smoothstep((phase - 0.97) / 0.03)


class Reference:
    """Periodic leg motion (Fourier fit of the first measured cycle)."""

    def __init__(self, cycles, seed):
        inverse = bundled_inverse("right")
        self.model = inverse.model
        start, end = inverse.first_cycle()
        keep = (inverse.time >= start) & (inverse.time <= end)
        phase = (inverse.time[keep] - start) / (end - start)
        k = np.arange(1, HARMONICS + 1)
        basis = np.column_stack([np.ones_like(phase), np.cos(2 * np.pi * np.outer(phase, k)),
                                 np.sin(2 * np.pi * np.outer(phase, k))])
        self.coefficients = np.linalg.lstsq(basis, inverse.q[keep], rcond=None)[0]
        rng = np.random.default_rng(seed)
        self.periods = (end - start) * (1 + 0.03 * rng.standard_normal(cycles))
        self.strikes = np.concatenate([[0.0], np.cumsum(self.periods)])

    def phase(self, t):
        """Cycle index and phase in [0, 1) at time t."""
        i = int(np.clip(np.searchsorted(self.strikes, t, side="right") - 1, 0,
                        len(self.periods) - 1))
        return i, (t - self.strikes[i]) / self.periods[i]

    def state(self, t):
        """q, v, a (nq,) of the reference at time t."""
        i, phase = self.phase(t)
        w = 2 * np.pi / self.periods[i]
        k = np.arange(1, HARMONICS + 1)
        c, s = np.cos(k * w * (t - self.strikes[i])), np.sin(k * w * (t - self.strikes[i]))
        a_cos, a_sin = self.coefficients[1:HARMONICS + 1], self.coefficients[HARMONICS + 1:]
        q = self.coefficients[0] + c @ a_cos + s @ a_sin
        v = (-k * w * s) @ a_cos + (k * w * c) @ a_sin
        a = (-(k * w) ** 2 * c) @ a_cos + (-(k * w) ** 2 * s) @ a_sin
        return q, v, a

    def ground_reaction(self, t, heel, toe):
        """Force, COP, free moment (3,) each: smooth stance load rolling heel to toe."""
        _, phase = self.phase(t)
        s = phase / STANCE
        window = _smoothstep(s / 0.05) * _smoothstep((1 - s) / 0.05) if s < 1 else 0.0
        force = np.array([120.0 * np.cos(np.pi * s), 0.0, 700.0 + 100 * np.sin(2 * np.pi * s)])
        cop = heel + min(max(s, 0.0), 1.0) * (toe - heel)
        cop[2] = 0.0
        return window * force, cop, np.zeros(3)


class FloatingLeg:
    """The leg free in the plane: hip load (reference + PD on the thigh pose), ground
    reaction, and joint torques (active + passive)."""

    def __init__(self, reference):
        self.ref = reference
        self.model = reference.model
        self.pm = self.model.pin_model
        self.data = self.pm.createData()
        self.hip = self.model.frame_id("hip_center")
        self.foot = self.model.frame_id("foot")
        self.heel, self.toe = self.model.frame_id("heel"), self.model.frame_id("toe")
        self._cache = {}

    def _terms(self, t, q, v):
        """Mass matrix, bias, planar hip Jacobian (3, 5), ground generalised force (5,)."""
        pm, data = self.pm, self.data
        mass = pin.crba(pm, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        bias = pin.nonLinearEffects(pm, data, q, v).copy()
        pin.computeJointJacobians(pm, data, q)
        pin.updateFramePlacements(pm, data)
        hip = pin.getFrameJacobian(pm, data, self.hip, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        force, cop, free = self.ref.ground_reaction(t, data.oMf[self.heel].translation,
                                                    data.oMf[self.toe].translation)
        foot = pin.getFrameJacobian(pm, data, self.foot, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        origin = data.oMf[self.foot].translation
        wrench = np.concatenate([force, np.cross(cop - origin, force) + free])
        return mass, bias, hip[[0, 2, 4]], foot.T @ wrench

    def _thigh(self, q, v, hip):
        position = self.data.oMf[self.hip].translation
        return np.array([position[0], position[2], q[2] + q[3] + q[4]]), hip @ v

    def reference_loads(self, t):
        """Joint torques (2,), hip wrench (3,), thigh pose and velocity of the reference."""
        key = round(t, 9)
        if key not in self._cache:
            self._cache = {k: v for k, v in self._cache.items() if k > key - 0.01}
            self._cache[key] = self._reference_loads(t)
        return self._cache[key]

    def _reference_loads(self, t):
        q, v, a = self.ref.state(t)
        mass, bias, hip, ground = self._terms(t, q, v)
        rhs = mass @ a + bias - ground
        w = np.linalg.solve(hip[:, :3].T, rhs[:3])
        pose, velocity = self._thigh(q, v, hip)
        return rhs[3:] - hip[:, 3:].T @ w, w, pose, velocity

    def torques(self, t, q, v, reference):
        """Active and passive model joint torques (2,) each."""
        q_ref, v_ref, _ = self.ref.state(t)
        knee_p, ankle_p = passive_clinical(-q[4], -v[4], q[3], v[3])
        passive = np.array([ankle_p, -knee_p])
        knee_r, ankle_r = passive_clinical(-q_ref[4], -v_ref[4], q_ref[3], v_ref[3])
        feedforward = reference[0] - np.array([ankle_r, -knee_r])
        pd = GAINS[0] * (q_ref[3:] - q[3:]) + GAINS[1] * (v_ref[3:] - v[3:])
        return active_gate(self.ref.phase(t)[1]) * (feedforward + pd), passive

    def rhs(self, t, x):
        q, v = x[:5], x[5:]
        reference = self.reference_loads(t)
        mass, bias, hip, ground = self._terms(t, q, v)
        pose, velocity = self._thigh(q, v, hip)
        wrench = reference[1] + HIP_GAINS[0] * (reference[2] - pose) \
            + HIP_GAINS[1] * (reference[3] - velocity)
        tau = np.zeros(5)
        tau[3:] = sum(self.torques(t, q, v, reference))
        a = np.linalg.solve(mass, tau + ground + hip.T @ wrench - bias)
        return np.concatenate([v, a])


def simulate(cycles=12, seed=0):
    """RK4 at STEP s; returns time (n,), q (n, 5), states (n, 10), reference, system."""
    ref = Reference(cycles, seed)
    system = FloatingLeg(ref)
    t = np.arange(0.0, ref.strikes[-1], STEP)
    q0, v0, _ = ref.state(0.0)
    x = np.concatenate([q0, v0])
    states = np.empty((len(t), 10))
    for i, ti in enumerate(t):
        states[i] = x
        if not np.all(np.abs(x) < 1e3):
            raise RuntimeError(f"synthetic walk diverged at t = {ti:.3f} s")
        k1 = system.rhs(ti, x)
        k2 = system.rhs(ti + STEP / 2, x + STEP / 2 * k1)
        k3 = system.rhs(ti + STEP / 2, x + STEP / 2 * k2)
        k4 = system.rhs(ti + STEP, x + STEP * k3)
        x = x + STEP / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return t, states[:, :5], states, ref, system


class NoiseFreeTrial:
    """The simulated walk sampled as a lab records it, before noise is added."""

    def __init__(self, cycles=12, seed=0, simulated=None):
        t, q, states, ref, system = simulated or simulate(cycles, seed)
        self.model = ref.model
        every = int(round(1 / (MARKER_RATE * STEP)))
        self.t_m, self.q_m = t[::every], q[::every]
        self.positions = frame_positions(self.model, self.q_m)
        self.t_p = np.arange(0.0, t[-1], 1 / PLATE_RATE)
        q_p = np.column_stack([np.interp(self.t_p, t, q[:, j]) for j in range(5)])
        feet = frame_positions(self.model, q_p)
        self.plate = [np.array(a) for a in zip(*(
            ref.ground_reaction(ti, heel, toe)
            for ti, heel, toe in zip(self.t_p, feet["heel"], feet["toe"], strict=True)),
            strict=True)]
        torques = [system.torques(ti, xi[:5], xi[5:], system.reference_loads(ti))
                   for ti, xi in zip(self.t_m, states[::every], strict=True)]
        active = np.array([a for a, _ in torques])
        passive = np.array([p for _, p in torques])
        self.truth = {"t": self.t_m, "q": self.q_m, "strikes": ref.strikes,
                      "passive": {"ankle": passive[:, 0], "knee": -passive[:, 1]},
                      "active": {"ankle": active[:, 0], "knee": -active[:, 1]}}

    def write(self, folder, *, noise_seed, marker_noise=1e-3, force_noise=0.01):
        """markers.csv, grf.mot and leg.urdf with this noise; the inverse options."""
        rng = np.random.default_rng(noise_seed)
        (folder / "leg.urdf").write_text(self.model.urdf)
        noisy = {k: v + rng.normal(0.0, marker_noise, v.shape)
                 for k, v in self.positions.items()}
        write_markers_csv(folder / "markers.csv", self.t_m, noisy)
        plate = list(self.plate)
        peak = np.abs(plate[0]).max(axis=0)
        plate[0] = plate[0] + np.where(plate[0][:, 2:3] > 0, 1.0, 0.0) * rng.normal(
            0.0, 1.0, plate[0].shape) * force_noise * peak
        write_grf_mot(folder / "grf.mot", self.t_p, [tuple(plate)])
        return InverseOptions(markers=folder / "markers.csv", grf=folder / "grf.mot",
                              mass=72.6, model=folder / "leg.urdf",
                              points={n: n for n in ("hip", "knee", "ankle", "heel", "toe")})


def quiet_curve_errors(truth, model, values, inverse, quiet):
    """Passive moment error of fitted ``values`` along the TRUE motion of the quiet samples.

    Per joint: RMS(fitted - true moment) / RMS(true moment), RMS(true moment) (N m), and
    the same error over the RMS of the true moment without its range-of-motion stops
    (the share of the elements the fit estimates; the stops are known settings). Both
    moments from ``model`` (the truth at :data:`TRUTH`; equal to :func:`passive_clinical`
    to 1e-15 N m), at the simulated angles and rates (central differences) at the times
    of the ``quiet`` (n,) samples. The inverse dynamics counts time from the first heel
    strike it detects (provenance ``time_zero_s``), the simulation from its start: the
    two clocks are joined here (issue 28 item 4's measure).
    """
    t = np.asarray(inverse.time)[quiet] + inverse.provenance["time_zero_s"]
    errors, sizes, unstopped = {}, {}, {}
    for joint, column, sign in (("knee", 4, -1.0), ("ankle", 3, 1.0)):
        angle = sign * np.interp(t, truth["t"], truth["q"][:, column])
        rate = sign * np.interp(t, truth["t"], np.gradient(truth["q"][:, column], truth["t"]))

        def moment(params, angle=angle, rate=rate, joint=joint):
            return np.asarray(model.passive_joint(joint, params).moment(angle, rate))

        true = moment({**values, **TRUTH})
        error = moment(values) - true
        free = moment({**values, **TRUTH, **{f"{joint}.{n}": 0.0 for n in ("k_lower", "k_upper")
                                             if f"{joint}.{n}" in values}})
        errors[joint] = float(np.sqrt(np.mean(error ** 2) / np.mean(true ** 2)))
        sizes[joint] = float(np.sqrt(np.mean(true ** 2)))
        unstopped[joint] = float(np.sqrt(np.mean(error ** 2) / np.mean(free ** 2)))
    return errors, sizes, unstopped


def write_trial(folder, *, cycles=12, seed=0, marker_noise=1e-3, force_noise=0.01):
    """Simulate and write markers.csv, grf.mot, leg.urdf; return options and the truth.

    Returns:
        (InverseOptions, dict with t, q, clinical passive and active moments (N m)).
    """
    trial = NoiseFreeTrial(cycles, seed)
    options = trial.write(folder, noise_seed=seed + 1000, marker_noise=marker_noise,
                          force_noise=force_noise)
    return options, trial.truth
