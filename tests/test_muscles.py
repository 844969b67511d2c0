"""DeGrooteFregly2016Muscle dynamics against OpenSim 4.6 and known answers.

Reference: tests/reference/osim2d/muscle_force.csv, written by OpenSim 4.6 itself
(make_reference.py, peer Python): 30 states x 18 muscles of 2D_gait.osim (rigid tendons),
isometric and at joint speeds up to 12 rad/s, with OpenSim's muscle-tendon length and
lengthening speed of each muscle, so the muscle model is checked apart from the paths.
"""

import csv
import math
from pathlib import Path

import casadi as cs
import numpy as np
import pytest
from scipy.optimize import brentq

from predgait.dynamics import muscle_curves as curves
from predgait.dynamics.muscles import MuscleParameters, MuscleSet
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait

REFERENCE = Path(__file__).resolve().parent / "reference" / "osim2d"
TABLE = REFERENCE / "muscle_force.csv"

#: OpenSim 4.6's activation derivative of iliopsoas_r in 2D_gait.osim, (excitation,
#: activation, da/dt in 1/s), printed once with the peer Python: controls set with
#: Muscle.setControls, model realized to Acceleration, getStateVariableDerivativeValue.
OPENSIM_ACTIVATION_RATES = (
    (0.9, 0.1, 48.28811281020588), (0.1, 0.9, -26.581615525543505), (0.5, 0.5, 0.0),
    (1.0, 0.02, 71.56171823738202), (0.02, 1.0, -32.66666666666667),
    (0.3, 0.6, -10.533604202487156),
)


@pytest.fixture(scope="module")
def muscles() -> MuscleSet:
    return MuscleSet.from_osim(bundled_2d_gait())


@pytest.fixture(scope="module")
def table() -> list[dict]:
    with TABLE.open() as handle:
        return list(csv.DictReader(handle))


def _column(table: list[dict], key: str) -> np.ndarray:
    """A table column as (n_muscles, n_states): rows are states x muscles in model order."""
    return np.array([float(r[key]) for r in table]).reshape(-1, 18).T


def _state(muscles: MuscleSet, table: list[dict], *, symbolic: bool = False):
    """Our rigid-tendon state at every table state, (n_muscles, n_states) arrays."""
    assert [r["muscle"] for r in table[:18]] == list(muscles.names)
    length, speed, activation = (_column(table, k) for k in
                                 ("length", "lengthening_speed", "activation"))
    if not symbolic:
        return muscles.rigid_tendon(length, speed, activation)
    x = [cs.SX.sym(k, len(muscles)) for k in ("l", "v", "a")]
    state = muscles.rigid_tendon(*x)
    f = cs.Function("f", x, [state.tendon_force, state.norm_fiber_velocity])
    outputs = f.map(length.shape[1])(length, speed, activation)
    return [np.asarray(v) for v in outputs]


def test_curves_known_answers():
    assert curves.active_force_length(1.0) == pytest.approx(1.0, abs=1e-15)
    assert curves.force_velocity(0.0) == pytest.approx(1.0, abs=1e-14)
    assert curves.force_velocity(-1.0) == pytest.approx(0.0, abs=1e-14)
    for strain in (0.3, 0.6, 0.9):
        assert curves.passive_force_length(1.0 + strain, strain) == pytest.approx(1.0, rel=1e-14)
        assert curves.passive_force_length(0.2, strain) == pytest.approx(0.0, abs=1e-15)
    for strain in (0.033, 0.049, 0.1):
        assert curves.tendon_force_length(1.0 + strain, strain) == pytest.approx(1.0, rel=1e-14)
        assert curves.tendon_force_length(1.0, strain) == pytest.approx(0.0, abs=1e-15)
    # Width scale w: f_L(1 + w (l - 1); w) = f_L(l; 1); inverse curves invert.
    lengths = np.linspace(0.4, 1.6, 13)
    assert np.allclose(curves.active_force_length(1.0 + 1.5 * (lengths - 1.0), 1.5),
                       curves.active_force_length(lengths), rtol=1e-14, atol=0)
    velocities = np.linspace(-1.0, 1.0, 11)
    assert np.allclose(curves.force_velocity_inverse(curves.force_velocity(velocities)),
                       velocities, atol=1e-12)
    forces = np.linspace(0.0, 2.0, 9)
    assert np.allclose(curves.tendon_force_length(curves.tendon_force_length_inverse(forces)),
                       forces, atol=1e-13)


def _rows(name: str) -> list[dict]:
    with (REFERENCE / name).open() as handle:
        return list(csv.DictReader(handle))


def test_curves_match_opensim_for_other_parameters():
    """muscle_curves.csv (make_muscle_curves.py): three parameter sets, x in [0.3, 1.9]."""
    rows = _rows("muscle_curves.csv")
    assert len({r["set"] for r in rows}) == 3
    for r in rows:
        x = float(r["x"])
        width, passive, tendon = (float(r[k]) for k in (
            "active_force_width_scale", "passive_fiber_strain_at_one_norm_force",
            "tendon_strain_at_one_norm_force"))
        assert curves.active_force_length(x, width) == pytest.approx(float(r["active"]),
                                                                      rel=1e-10, abs=1e-12)
        assert curves.passive_force_length(x, passive) == pytest.approx(float(r["passive"]),
                                                                         rel=1e-10, abs=1e-12)
        assert curves.tendon_force_length(x, tendon) == pytest.approx(float(r["tendon"]),
                                                                       rel=1e-10, abs=1e-12)
        assert curves.force_velocity(x - 1.0) == pytest.approx(float(r["velocity"]),
                                                                rel=1e-10, abs=1e-12)


def test_compliant_residual_matches_opensim(muscles):
    """compliant_residual.csv: OpenSim 4.6's calcEquilibriumResidual (implicit mode) of the
    18 muscles at 12 random states each (normalized by the max isometric force)."""
    rows = _rows("compliant_residual.csv")
    index = np.array([muscles.index(r["muscle"]) for r in rows])
    values = {k: np.array([float(r[k]) for r in rows]) for k in rows[0] if k != "muscle"}
    for i in range(len(muscles)):
        pick = index == i
        one = MuscleSet((muscles.muscles[i],))
        state = one.compliant_tendon(*(values[k][pick][None, :] for k in (
            "length", "speed", "activation", "norm_tendon_force", "norm_tendon_force_rate")))
        assert np.allclose(state.residual[0], values["residual"][pick], rtol=1e-9, atol=1e-11)
    assert np.abs(values["residual"]).max() > 0.5


def test_activation_rate_as_opensim_and_its_sign():
    for excitation, activation, rate in OPENSIM_ACTIVATION_RATES:
        assert curves.activation_rate(excitation, activation) == pytest.approx(
            rate, rel=1e-12, abs=1e-12)
    e, a = np.meshgrid(np.linspace(0.0, 1.0, 11), np.linspace(0.01, 1.0, 11))
    assert np.array_equal(np.sign(curves.activation_rate(e, a)), np.sign(e - a))


def test_tendon_force_matches_opensim(muscles, table):
    state = _state(muscles, table)
    reference = _column(table, "tendon_force")
    error = np.abs(state.tendon_force - reference)
    assert np.all(error <= 1e-6 * np.abs(reference) + 1e-9), error.max()
    assert np.abs(reference).max() > 1000.0         # the table holds large forces too
    assert np.abs(_column(table, "normalized_fiber_velocity")).max() > 0.8  # fast states too


@pytest.mark.parametrize("ours, theirs", [
    ("fiber_length", "fiber_length"), ("norm_fiber_length", "normalized_fiber_length"),
    ("fiber_velocity", "fiber_velocity"), ("norm_fiber_velocity", "normalized_fiber_velocity"),
    ("active_force_length", "active_force_length_multiplier"),
    ("force_velocity", "force_velocity_multiplier"),
    ("passive_force_length", "passive_force_multiplier"),
    ("active_fiber_force", "active_fiber_force"),
    ("passive_fiber_force", "passive_fiber_elastic_force"),
    ("damping_force", "passive_fiber_damping_force"), ("fiber_force", "fiber_force"),
])
def test_fibre_quantities_match_opensim(muscles, table, ours, theirs):
    value = getattr(_state(muscles, table), ours)
    reference = _column(table, theirs)
    assert np.allclose(value, reference, rtol=1e-8, atol=1e-9)


def test_pennation_matches_opensim(muscles, table):
    state = _state(muscles, table)
    reference = _column(table, "pennation_angle")
    width = np.array([m.fiber_width for m in muscles.muscles])[:, None]
    # OpenSim: asin(width / fibre length) (a muscle-tendon shorter than its slack tendon has
    # cos(alpha) = -1 at zero pennation, as in OpenSim; the tendon force matches there too).
    assert np.allclose(np.arcsin(width / state.fiber_length), reference, atol=1e-9)


def test_casadi_equals_numpy(muscles, table):
    state = _state(muscles, table)
    force, velocity = _state(muscles, table, symbolic=True)
    assert np.allclose(force, state.tendon_force, rtol=1e-13, atol=1e-9)
    assert np.allclose(velocity, state.norm_fiber_velocity, rtol=1e-13, atol=1e-13)


def test_stiff_compliant_tendon_tends_to_rigid(muscles):
    """At equilibrium (residual 0, f_T constant) a very stiff tendon carries the rigid force."""
    stiff = muscles.edited(muscles.names, tendon_strain_at_one_norm_force=1e-7)
    lengths = np.array([m.tendon_slack_length + 1.05 * m.optimal_fiber_length
                        for m in muscles.muscles])
    speed, activation = np.zeros(len(muscles)), np.full(len(muscles), 0.7)
    rigid = muscles.rigid_tendon(lengths, speed, activation).tendon_force
    for i in range(len(muscles)):
        one = MuscleSet((stiff.muscles[i],))

        def residual(force, one=one, i=i):
            state = one.compliant_tendon(lengths[[i]], speed[[i]], activation[[i]],
                                         np.array([force]), np.zeros(1))
            return float(state.residual[0])

        force = brentq(residual, 1e-9, 5.0, xtol=1e-14)
        assert force * muscles.muscles[i].max_isometric_force == pytest.approx(rigid[i],
                                                                             rel=1e-5)


def test_compliant_residual_is_tendon_minus_fibre_force(muscles):
    lengths = np.array([m.tendon_slack_length * 1.02 + m.optimal_fiber_length
                        for m in muscles.muscles])
    f_t, rate = np.full(len(muscles), 0.4), np.full(len(muscles), 2.0)
    state = muscles.compliant_tendon(lengths, np.full(len(muscles), 0.1),
                                     np.full(len(muscles), 0.5), f_t, rate)
    f_max = muscles.parameter("max_isometric_force")
    assert np.allclose(state.tendon_force, f_max * f_t)
    assert np.allclose(state.residual, (state.tendon_force
                       - state.fiber_force * state.cos_pennation) / f_max)
    # The tendon takes the strain of f_T = 0.4, the fibre the rest of the length.
    strain = muscles.parameter("tendon_strain_at_one_norm_force")
    assert np.allclose(curves.tendon_force_length(state.norm_tendon_length, strain), 0.4)


def test_scenario_edits(muscles):
    weak = muscles.edited(["soleus_r", "gastroc_r"], max_isometric_force_scale=0.5,
                          where="surgery.toml: [muscles]")
    i = muscles.index("soleus_r")
    lengths = np.array([m.tendon_slack_length + 1.1 * m.optimal_fiber_length
                        for m in muscles.muscles])
    zero, half = np.zeros(len(muscles)), np.full(len(muscles), 0.5)
    original = muscles.rigid_tendon(lengths, zero, half)
    before = original.tendon_force
    after = weak.rigid_tendon(lengths, zero, half).tendon_force
    assert after[i] == pytest.approx(0.5 * before[i], rel=1e-14)
    assert after[muscles.index("tib_ant_r")] == before[muscles.index("tib_ant_r")]
    off = muscles.edited("soleus_r", applies_force=False).rigid_tendon(lengths, zero, half)
    assert off.tendon_force[i] == 0.0 and off.fiber_force[i] == original.fiber_force[i]
    longer = muscles.edited("hamstrings_r", tendon_slack_length_scale=1.1)
    assert longer.muscles[0].tendon_slack_length == pytest.approx(
        1.1 * muscles.muscles[0].tendon_slack_length)
    stiffer = muscles.edited("vasti_l", passive_fiber_strain_at_one_norm_force=0.3,
                             optimal_fiber_length=0.09)
    j = muscles.index("vasti_l")
    assert (stiffer.muscles[j].passive_fiber_strain_at_one_norm_force,
            stiffer.muscles[j].optimal_fiber_length) == (0.3, 0.09)
    assert muscles.muscles[j].optimal_fiber_length != 0.09          # the original stays


def test_bad_edits_and_parameters_name_the_place(muscles):
    with pytest.raises(InputError, match=r"surgery.toml: .*no muscle named 'soleus'.*soleus_r"):
        muscles.edited("soleus", max_isometric_force_scale=0.5, where="surgery.toml: [a]")
    with pytest.raises(InputError, match="unknown muscle parameter 'strength'"):
        muscles.edited("soleus_r", strength=2.0)
    with pytest.raises(InputError, match=r"surgery.toml: muscle 'soleus_r': "
                                         r"optimal_fiber_length = 0.0 must be > 0"):
        muscles.edited("soleus_r", optimal_fiber_length=0.0, where="surgery.toml")
    with pytest.raises(InputError, match=r"2D_gait.osim, line \d+: muscle 'x': "
                                         "tendon_slack_length = -0.1"):
        MuscleParameters("x", 1000.0, 0.1, -0.1, where="2D_gait.osim, line 7")
    with pytest.raises(InputError, match="pennation_angle_at_optimal"):
        MuscleParameters("x", 1000.0, 0.1, 0.2, pennation_angle_at_optimal=math.pi / 2)


def test_from_osim_reads_the_file(muscles):
    assert len(muscles) == 18 and muscles.names[0] == "hamstrings_r"
    soleus = muscles.muscles[muscles.index("soleus_r")]
    assert (soleus.max_isometric_force, soleus.tendon_slack_length) == (5137.0, 0.240852755622514)
    assert soleus.fiber_damping == 0.01 and soleus.ignore_tendon_compliance
    assert soleus.passive_fiber_strain_at_one_norm_force == 0.6      # OpenSim's default
    assert "2D_gait.osim, line" in soleus.where
