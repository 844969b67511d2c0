"""Bhargava et al. (2004) metabolic rates against OpenSim 4.6's smoothed metabolics.

Reference: tests/reference/osim2d/metabolics.csv, written by OpenSim 4.6 itself
(make_metabolics.py, peer Python): Bhargava2004SmoothedMuscleMetabolics on all 18 muscles of
2D_gait.osim (and one component per muscle for the separate terms), 40 sampled states with
activations set as states and excitations through the model's controls, OpenSim's default
(0.5) and literature slow-twitch ratios. Each muscle's state is rebuilt here from OpenSim's
muscle-tendon length and lengthening speed, so metabolics are checked apart from the paths.
metabolics_gait.csv: OpenSim's rates along Moco's own example2DWalking tracking solution
(full cycle), for the cost of transport of a whole stride.
"""

import csv
import math
from pathlib import Path

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics import metabolics as mb
from predgait.dynamics.muscles import MuscleSet
from predgait.errors import InputError
from predgait.models.osim import bundled_2d_gait

REFERENCE = Path(__file__).resolve().parent / "reference" / "osim2d"
TABLE = REFERENCE / "metabolics.csv"
#: OpenSim's rates along Moco's example2DWalking tracking solution (make_metabolics.py).
GAIT = REFERENCE / "metabolics_gait.csv"
TERMS = {"activation_rate": "activation", "maintenance_rate": "maintenance",
         "shortening_rate": "shortening", "mechanical_work_rate": "mechanical_work",
         "metabolic_rate": "muscle"}
#: Relative tolerance, of each muscle's largest term at the state (a muscle's total can be
#: ~0 where its heat cancels negative work, so a bare relative error means nothing there).
RTOL = 1e-6


@pytest.fixture(scope="module")
def muscles() -> MuscleSet:
    return MuscleSet.from_osim(bundled_2d_gait())


def _table(muscles, ratios):
    rows = [r for r in csv.DictReader(TABLE.open()) if r["ratios"] == ratios]
    n = len(muscles)
    assert [r["muscle"] for r in rows[:n]] == list(muscles.names)

    def column(key):
        return np.array([float(r[key]) for r in rows]).reshape(-1, n).T

    return column


@pytest.mark.parametrize("ratios", ["default", "literature"])
def test_rates_match_opensim(muscles, ratios):
    column = _table(muscles, ratios)
    state = muscles.rigid_tendon(column("length"), column("lengthening_speed"),
                                 column("activation"))
    table = None if ratios == "default" else mb.SLOW_TWITCH_LITERATURE
    np.testing.assert_allclose(mb.slow_twitch_ratios(muscles, table),
                               column("slow_twitch_ratio")[:, 0], rtol=0, atol=1e-11)
    rates = mb.metabolic_rates(muscles, state, column("excitation"), column("activation"),
                               body_mass=float(column("model_mass")[0, 0]),
                               options=mb.BhargavaOptions(slow_twitch=table))
    scale = np.max([np.abs(column(k)) for k in TERMS], axis=0)
    for key, field in TERMS.items():
        error = np.abs(getattr(rates, field) - column(key)) / scale
        assert error.max() < RTOL, (key, error.max())
    total = column("total_metabolic_rate")[0]
    assert np.max(np.abs(rates.total - total) / total) < RTOL
    # the smoothing is exercised: shortening and lengthening, the 1 W/kg floor binding
    velocity = column("fiber_velocity")
    assert (velocity < -0.05).any() and (velocity > 0.05).any()
    mass = mb.muscle_masses(muscles)[:, None]
    heat = sum(column(k) for k in ("activation_rate", "maintenance_rate", "shortening_rate"))
    assert (heat < 0.5 * mass).any()


def test_muscle_mass_known_answer(muscles):
    # F_max / 0.25 MPa * 1059.7 kg/m^3 * l_opt
    row = muscles.index("soleus_r")
    p = muscles.muscles[row]
    expected = p.max_isometric_force / 0.25e6 * 1059.7 * p.optimal_fiber_length
    assert mb.muscle_masses(muscles)[row] == pytest.approx(expected, rel=1e-15)


def test_casadi_equals_numpy(muscles):
    column = _table(muscles, "default")
    k = 25
    args = [column(key)[:, k] for key in ("length", "lengthening_speed", "activation",
                                           "excitation")]
    length, speed, act, exc = (cs.SX.sym(n, len(muscles)) for n in "lsae")
    state = muscles.rigid_tendon(length, speed, act)
    rates = mb.metabolic_rates(muscles, state, exc, act, body_mass=62.0)
    f = cs.Function("rates", [length, speed, act, exc], [rates.muscle, rates.total])
    muscle, total = (np.array(v).ravel() for v in f(*args))
    ref = mb.metabolic_rates(muscles, muscles.rigid_tendon(*args[:3]), args[3], args[2],
                             body_mass=62.0)
    np.testing.assert_allclose(muscle, ref.muscle, rtol=1e-12, atol=1e-12)
    assert total[0] == pytest.approx(ref.total, rel=1e-12)
    # smooth: the gradient exists everywhere (tanh blends, no branches)
    grad = cs.Function("g", [length, speed, act, exc],
                       [cs.gradient(rates.total, cs.vertcat(speed, exc))])
    assert np.all(np.isfinite(np.array(grad(*args))))


def test_basal_only_when_idle(muscles):
    # zero excitation, isometric at optimal length: no heat but the 1 W/kg floor, reached
    # through OpenSim's tanh blend with k = 10 /W: m (1/2 + tanh(10 m) / 2)
    n = len(muscles)
    length = np.array([m.tendon_slack_length + m.optimal_fiber_length for m in muscles.muscles])
    state = muscles.rigid_tendon(length, np.zeros(n), np.zeros(n))
    rates = mb.metabolic_rates(muscles, state, np.zeros(n), np.zeros(n), body_mass=62.0)
    assert rates.basal == pytest.approx(1.2 * 62.0)
    mass = mb.muscle_masses(muscles)
    floor = mass * (0.5 + 0.5 * np.tanh(10.0 * mass))
    np.testing.assert_allclose(rates.muscle, floor, rtol=1e-12)
    off = mb.metabolic_rates(muscles, state, np.zeros(n), np.zeros(n), body_mass=62.0,
                             options=mb.BhargavaOptions(basal_coefficient=0.0))
    assert off.total == pytest.approx(float(np.sum(floor)), rel=1e-12)


def test_cost_of_transport_known_answer():
    t = np.linspace(0.0, 1.0, 11)
    # 310 W for 1 s over 1.25 m by a 62 kg body: 4 J/kg/m
    assert mb.cost_of_transport(t, np.full(11, 310.0), mass=62.0, distance=1.25) == \
        pytest.approx(4.0)
    # trapezoid of a linear rate is exact
    assert mb.cost_of_transport(t, 100.0 + 200.0 * t, mass=1.0, distance=1.0) == \
        pytest.approx(200.0)
    with pytest.raises(InputError, match="distance"):
        mb.cost_of_transport(t, np.ones(11), mass=62.0, distance=0.0)
    with pytest.raises(InputError, match="two"):
        mb.cost_of_transport(t, np.ones(10), mass=62.0, distance=1.0)


def test_stride_rates_from_paths(muscles):
    from predgait.dynamics.muscle_paths import smooth_paths
    from predgait.models.osim_model import build_model

    built = build_model(bundled_2d_gait())
    paths = smooth_paths(built, on_model_q=True)
    n_nodes = 5
    q = np.tile(built.default_q(), (n_nodes, 1))
    knee = built.osim_coordinates.index("knee_angle_r")
    q[:, knee] = np.linspace(-0.6, -0.1, n_nodes)
    v = np.zeros_like(q)
    v[:, knee] = 0.5 / 0.4
    exc = np.full((n_nodes, len(muscles)), 0.2)
    rates = mb.stride_rates(muscles, paths, q, v, exc, exc, body_mass=62.0)
    assert rates.muscle.shape == (len(muscles), n_nodes)
    state = muscles.rigid_tendon(paths.lengths(q[2]), paths.lengthening_speeds(q[2], v[2]),
                                 exc[2])
    one = mb.metabolic_rates(muscles, state, exc[2], exc[2], body_mass=62.0)
    np.testing.assert_allclose(rates.total[2], one.total, rtol=1e-12)
    assert math.isfinite(mb.cost_of_transport(np.linspace(0, 0.4, n_nodes), rates.total,
                                              mass=62.0, distance=0.5))


def test_bad_slow_twitch_table(muscles):
    with pytest.raises(InputError, match="soleus_r"):
        mb.slow_twitch_ratios(muscles, {**mb.SLOW_TWITCH_LITERATURE, "soleus": 1.5})


def test_stride_cost_of_transport_along_moco_gait(muscles):
    """Moco's example2DWalking tracking solution (full cycle): OpenSim's rates at every
    state, and the cost of transport from q, v through predgait's smooth paths."""
    from types import SimpleNamespace

    from predgait.dynamics.muscle_paths import smooth_paths
    from predgait.models.osim_model import build_model

    rows = list(csv.DictReader(GAIT.open()))

    def column(key):
        return np.array([float(r[key]) for r in rows])

    def per_muscle(key):
        return np.array([column(f"{m}.{key}") for m in muscles.names])

    t, mass = column("time"), float(column("model_mass")[0])
    state = muscles.rigid_tendon(per_muscle("length"), per_muscle("lengthening_speed"),
                                 per_muscle("activation"))
    rates = mb.metabolic_rates(muscles, state, per_muscle("excitation"),
                               per_muscle("activation"), body_mass=mass)
    reference = per_muscle("metabolic_rate")
    assert np.max(np.abs(rates.muscle - reference)) < RTOL * np.max(np.abs(reference))
    total = column("total_metabolic_rate")
    np.testing.assert_allclose(rates.total, total, rtol=RTOL)
    distance = column("pelvis_tx")[-1] - column("pelvis_tx")[0]
    opensim_cot = mb.cost_of_transport(t, total, mass=mass, distance=distance)
    assert 3.0 < opensim_cot < 6.0          # J/kg/m, gross (basal included)
    built = build_model(bundled_2d_gait())
    q = built.q_from_osim({n: column(n) for n in built.osim_coordinates})
    v = built.q_from_osim({n: column(f"{n}.speed") for n in built.osim_coordinates})
    stride = SimpleNamespace(t=t, q=q, v=v, act=per_muscle("activation").T,
                             exc=per_muscle("excitation").T, distance=distance)
    cot, along = mb.stride_cost_of_transport(stride, muscles,
                                             smooth_paths(built, on_model_q=True),
                                             body_mass=mass)
    assert cot == pytest.approx(opensim_cot, rel=1e-3)   # path fits: 0.2 mm, 1.3 mm/s
    assert along.total.shape == t.shape
