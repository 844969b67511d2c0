"""Partitioned forward dynamics (predgait.dynamics.partitioned) on the 35-DOF body.

Known answers: with nothing prescribed it is ABA; with the joints prescribed the free
pelvis accelerations and the joint reactions satisfy RNEA (zero pelvis rows, joint rows
= reactions); with no external force the whole-body centre of mass falls ballistically
(COM theorem), whatever the joints do.
"""

import numpy as np
import pinocchio as pin
import pytest

from predgait.dynamics.contact import ImpactContact
from predgait.dynamics.forces import GroundContact
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.inverse3d import velocities
from predgait.dynamics.motion import MotionHistory
from predgait.dynamics.partitioned import (
    PartitionedSystem,
    simulate_partitioned,
)
from predgait.errors import InputError
from predgait.models.loading import load_model
from predgait.models.loading3d import load_fullbody


@pytest.fixture(scope="module")
def body():
    return load_fullbody()


@pytest.fixture(scope="module")
def swinging(body):
    rng = np.random.default_rng(1)
    time = np.linspace(0.0, 1.0, 101)
    q = np.tile(body.neutral(), (time.size, 1))
    q[:, 7:] += 0.3 * np.sin(3 * time)[:, None] * rng.uniform(-1, 1, 29)
    v, a = velocities(body, time, q)
    return MotionHistory(body, time, q, v, a)


def test_nothing_prescribed_is_aba(body):
    pm = body.pin_model
    rng = np.random.default_rng(0)
    q = body.neutral()
    q[7:] = 0.2 * rng.uniform(-1, 1, 29)
    v, tau = rng.normal(size=pm.nv), rng.normal(size=pm.nv)
    system = PartitionedSystem(body, range(pm.nv), lambda t: (q.copy(), v.copy(), 0 * v),
                               [lambda t, q_, v_, data: tau])
    xdot = system(0.0, system.state(q, v))
    np.testing.assert_allclose(xdot[system.nqf:], pin.aba(pm, pm.createData(), q, v, tau),
                               atol=1e-10)


def test_prescribed_joints_satisfy_rnea(body, swinging):
    pm = body.pin_model
    system = PartitionedSystem(body, range(6), swinging)
    q, v, a = swinging(0.5)
    a_free, reaction = system.solve(0.5, *system.full_state(0.5, system.state(q, v)))
    a[:6] = a_free
    tau = pin.rnea(pm, pm.createData(), q, v, a)
    np.testing.assert_allclose(tau[:6], 0.0, atol=1e-9)
    np.testing.assert_allclose(tau[6:], reaction, atol=1e-9)


def test_centre_of_mass_falls_ballistically(body, swinging):
    pm, data = body.pin_model, body.pin_model.createData()
    system = PartitionedSystem(body, range(6), swinging)
    q0, v0, _ = swinging(0.0)
    run = simulate_partitioned(system, (0.0, 0.3), system.state(q0, v0),
                               options=IntegratorOptions(method=Method.RK4, step=1e-3))
    c0 = pin.centerOfMass(pm, data, run.q[0], run.v[0]).copy()
    vc0 = data.vcom[0].copy()
    t = run.t[-1]
    expected = c0 + vc0 * t + 0.5 * np.array([0.0, 0.0, -9.81]) * t**2
    np.testing.assert_allclose(pin.centerOfMass(pm, data, run.q[-1]), expected, atol=2e-5)
    assert np.allclose(np.linalg.norm(run.q[:, 3:7], axis=1), 1.0)


def test_standing_on_contact_carries_body_weight():
    """gait7 standing on four heel/toe contacts, joints held: total contact force = m g."""
    model = load_model("urdf/gait7.urdf")
    pm = model.pin_model
    q = np.zeros(pm.nq)
    data = pm.createData()
    pin.framesForwardKinematics(pm, data, q)
    sole = min(data.oMf[model.frame_id(f)].translation[2] for f in ("heel_r", "toe_r"))
    contact = GroundContact(model, ("heel_r", "toe_r", "heel_l", "toe_l"),
                            ImpactContact(damping_depth=5e-4), ground_z=sole, planar=True)
    motion = lambda t: (q.copy(), np.zeros(pm.nv), np.zeros(pm.nv))  # noqa: E731
    system = PartitionedSystem(model, [1], motion, [contact])  # only the height is free
    run = simulate_partitioned(system, (0.0, 1.5), system.state(q, np.zeros(pm.nv)),
                               options=IntegratorOptions(method=Method.RK4, step=2e-4))
    weight = sum(pm.inertias[i].mass for i in range(pm.njoints)) * 9.81
    forces = contact.forces_at(run.q[-1], run.v[-1])
    assert forces[:, 2].sum() == pytest.approx(weight, rel=1e-3)
    # The same forces as the system applies (no state kept between the calls).
    tau = system.applied(run.t[-1], run.q[-1], run.v[-1])
    assert np.allclose(contact.forces(system.data), forces, rtol=0, atol=1e-9)
    assert np.isfinite(tau).all()
    from dataclasses import FrozenInstanceError

    with pytest.raises(FrozenInstanceError):
        contact.ground_z = 0.0
    assert not hasattr(contact, "last_forces")
    assert abs(run.v[-1, 1]) < 1e-3


def test_partial_free_flyer_is_refused(body, swinging):
    with pytest.raises(InputError, match="free-flyer"):
        PartitionedSystem(body, [0, 1, 6], swinging)


@pytest.mark.parametrize("free", [range(6), range(6, 20), [0, 1, 2, 9, 10]])
def test_engine_equals_the_partitioned_equations(body, swinging, free):
    """Pinocchio's RNEA/CRBA path equals a_f = M_ff^-1 (tau_f - h_f - M_fp a_p) (the form
    the CasADi problems use) for prescribed pelvis, joints or a mix."""
    from predgait.dynamics.partitioned import free_accelerations

    pm = body.pin_model
    rng = np.random.default_rng(4)
    tau = rng.normal(0.0, 20.0, pm.nv)
    system = PartitionedSystem(body, free, swinging, [lambda t, q, v, data: tau])
    q, v, a = swinging(0.3)
    a_free, _ = system.solve(0.3, q, v, a)
    data = pm.createData()
    mass = pin.crba(pm, data, q)
    mass = np.triu(mass) + np.triu(mass, 1).T
    expected = free_accelerations(mass, pin.nonLinearEffects(pm, data, q, v), tau,
                                  a[system.pres], list(system.free), list(system.pres))
    np.testing.assert_allclose(a_free, expected, rtol=1e-9, atol=1e-9)


def test_leg_pivot_path_equals_the_general_partition():
    """The leg's one-ABA pivot path (time's shifts cached, several states per time, as in
    a modified-Euler step) equals the general partition (RNEA + CRBA solve) for the driven
    re-synthesis: moving base, measured moments, hip load in the lab frame."""
    from dataclasses import replace

    from predgait.dynamics.drivers import LegDrivers
    from predgait.dynamics.forward import LegSystem
    from predgait.dynamics.inverse_trial import bundled_inverse

    inverse = bundled_inverse("right")
    rng = np.random.default_rng(3)
    for hip_in_thigh in (False, True):
        drivers = replace(LegDrivers.from_inverse(inverse), hip_in_thigh_frame=hip_in_thigh)
        fast, general = LegSystem(inverse.model, drivers), LegSystem(inverse.model, drivers)
        assert fast._pivot is not None
        general._pivot = None
        for t in np.linspace(0.0, 1.0, 7):
            for _ in range(3):
                x = np.concatenate([rng.uniform(-0.8, 0.3, 2), rng.uniform(-4.0, 4.0, 2)])
                np.testing.assert_allclose(fast(t, x), general(t, x), rtol=1e-9, atol=1e-9)
                q, v, a = fast.full_state(t, x)
                np.testing.assert_allclose(fast.accelerations(t, q, v, a), general(t, x)[2:],
                                           rtol=1e-9, atol=1e-9)
