"""Node dynamics of the muscle-driven planar gait model (OpenSim's 2D_gait.osim), CasADi SX.

One function of one collocation node, mapped over the grid by
:mod:`predgait.problems.muscle_gait`. Implicit skeletal dynamics (Falisse et al. 2019,
J R Soc Interface 16:20190402; van den Bogert et al. 2011, Procedia IUTAM 2:297-316):
the accelerations are controls and

    r = M(q) a + h(q, v) - R(q)^T F_T(act, q, v) - e_lumbar u_lumbar F_opt
        - sum_c J_c(q)^T F_c(q, v)                                         (= 0)

with M, h from ADAM on the same URDF as Pinocchio (:mod:`predgait.models.symbolic`),
R = -dl/dq the muscle moment arms and F_T the rigid-tendon DeGrooteFregly2016 forces
(:mod:`predgait.dynamics.muscles`, lengths l(q) from :mod:`predgait.dynamics.muscle_paths`),
the lumbar CoordinateActuator (control times its optimal force), the model's
SpringGeneralizedForce elements (in the muscle term above; e.g. a passive toe joint) and the
SmoothSphereHalfSpaceForce contacts (:mod:`predgait.dynamics.smooth_contact`), each applied
at its sphere's contact point. Activation dynamics: d act/dt = f(exc, act) (De Groote
et al. 2016, Ann Biomed Eng 44:2922, as OpenSim's DeGrooteFregly2016Muscle).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as cs
import numpy as np

from predgait.models.symbolic import base_transform, symbolic_model


@dataclass(frozen=True)
class Sphere:
    """A contact sphere: name, predgait link, centre in the link frame (m), radius (m)."""

    name: str
    link: str
    location: tuple[float, float, float]
    radius: float


@dataclass(frozen=True, eq=False)
class MusclePlant:
    """Everything one node needs: the skeleton, muscles, the lumbar actuator, contacts.

    Attributes:
        model: the predgait Model (Pinocchio) of 2D_gait.osim.
        osim: the osim model object it came from (:func:`predgait.models.osim.read_osim`).
        muscle_names: in the order of the activations and excitations.
        muscle_set: the DeGrooteFregly2016 parameters (:mod:`predgait.dynamics.muscles`).
        paths: smooth muscle-tendon lengths l(q) (:mod:`predgait.dynamics.muscle_paths`).
        lumbar_row: model coordinate index driven by the lumbar actuator.
        lumbar_optimal_force: N m per unit control.
        lumbar_control_range: (min_control, max_control) of the actuator.
        excitation_range: (min_control, max_control) of the muscles.
        spheres: the contact spheres; contacts: their force laws (same order).
        springs: the model's SpringGeneralizedForce elements
            (:class:`~predgait.dynamics.joint_springs.JointSpring`, e.g. a passive toe).
        coordinates, signs: each model row's OpenSim coordinate and model = sign * OpenSim.
        compliant: rows of the muscles whose tendons are compliant in the NLP (De Groote
            et al. 2016's implicit form: the normalized tendon force a state, its rate a
            control, the fibre-tendon equilibrium a constraint); the others are rigid.
    """

    model: object
    osim: object
    muscle_names: tuple[str, ...]
    muscle_set: object
    paths: object
    lumbar_row: int
    lumbar_optimal_force: float
    lumbar_control_range: tuple[float, float]
    excitation_range: tuple[float, float]
    spheres: tuple[Sphere, ...]
    contacts: tuple
    springs: tuple = ()
    coordinates: tuple[str, ...] = ()
    signs: tuple[float, ...] = ()
    compliant: tuple[int, ...] = ()

    @property
    def rigid(self) -> tuple[int, ...]:
        """Rows of the muscles with rigid tendons (the others: :attr:`compliant`)."""
        return tuple(i for i in range(self.n_muscles) if i not in self.compliant)

    def subset(self, rows) -> object:
        """The :class:`~predgait.dynamics.muscles.MuscleSet` of some muscles' rows."""
        return type(self.muscle_set)(tuple(self.muscle_set.muscles[i] for i in rows))

    def spring_forces(self, q, v):
        """(nq,) generalised forces of the model's springs (numpy or CasADi column)."""
        from predgait.dynamics.joint_springs import spring_forces

        return spring_forces(self.springs, self.coordinates, self.signs, q, v)

    @property
    def n_muscles(self) -> int:
        """Number of muscles."""
        return len(self.muscle_names)


def link_point(model, link: str, location) -> cs.Function:
    """``point(q) -> p``: lab position (m) of a point fixed in a link (ADAM kinematics)."""
    sym = symbolic_model(model)
    q = cs.SX.sym("q", model.nq)
    transform = sym.kindyn.forward_kinematics(link, base_transform(q[:3]), q[3:])
    p = transform[:3, 3] + transform[:3, :3] @ cs.DM(np.asarray(location, dtype=float))
    return cs.Function(f"point_{link}", [q], [p], ["q"], ["p"])


@functools.lru_cache(maxsize=8)
def node_function(plant: MusclePlant, metabolic: bool = False) -> cs.Function:
    """The dynamics of one node (residual, activation rate, contact and muscle forces).

    ``node(q, v, a, act, exc, u[, ft, dft]) -> (r, act_dot, grf, points, force, fibre,
    tau_m, met, tendon)``. Inputs: q, v, a (nq,) model coordinates, rates, accelerations;
    act, exc (m,) activations and excitations; u (1,) lumbar control; with compliant tendons
    (``plant.compliant``, c muscles) ft (c,) their normalized tendon forces and dft (c,)
    its rates, 1/s. Outputs: r (nq,) the residual
    (N, N m); act_dot (m,) 1/s; grf (3 n_spheres,) contact forces on the spheres in the lab
    frame (N); points (3 n_spheres,) where they act (m); force (m,) tendon forces (N);
    fibre (m,) normalised fibre velocities; tau_m (nq,) muscle generalised forces (N m);
    met (1,) the muscles' metabolic rate, W (Bhargava 2004 as OpenSim 4.6's smoothed probe,
    :mod:`predgait.dynamics.metabolics`; basal rate not included), or 0 unless
    ``metabolic`` (its expression costs ~60 % more build and solve time); tendon (c,) the
    compliant muscles' equilibrium residuals f_T - F_fibre cos(alpha) / F_max
    (:meth:`~predgait.dynamics.muscles.MuscleSet.compliant_tendon`; empty when rigid).
    """
    from predgait.dynamics.metabolics import metabolic_rates

    model, nq, m = plant.model, plant.model.nq, plant.n_muscles
    sym = symbolic_model(model)
    q, v, a = (cs.SX.sym(n, nq) for n in ("q", "v", "a"))
    act, exc, u = cs.SX.sym("act", m), cs.SX.sym("exc", m), cs.SX.sym("u", 1)
    nc = len(plant.compliant)
    ft, dft = cs.SX.sym("ft", nc), cs.SX.sym("dft", nc)
    length = plant.paths.lengths(q)
    arms = -cs.jacobian(length, q)                       # (m, nq), = moment arms
    speed = -(arms @ v)                                  # lengthening speed, m/s
    force, fibre = cs.SX.zeros(m, 1), cs.SX.zeros(m, 1)
    metabolic_rate, tendon = cs.SX.zeros(1, 1), cs.SX.zeros(nc, 1)
    for rows, compliant in ((plant.rigid, False), (plant.compliant, True)):
        if not rows:
            continue
        muscles, pick = plant.subset(rows), list(rows)
        state = (muscles.compliant_tendon(length[pick], speed[pick], act[pick], ft, dft)
                 if compliant else muscles.rigid_tendon(length[pick], speed[pick], act[pick]))
        force[pick] = state.tendon_force
        fibre[pick] = state.norm_fiber_velocity
        if compliant:
            tendon = state.residual
        if metabolic:
            metabolic_rate += cs.sum1(metabolic_rates(muscles, state, exc[pick], act[pick],
                                                      body_mass=model.total_mass()).muscle)
    act_dot = plant.muscle_set.activation_rate(exc, act)
    muscle_tau = arms.T @ force
    applied = muscle_tau + (plant.spring_forces(q, v) if plant.springs else 0)
    applied[plant.lumbar_row] += plant.lumbar_optimal_force * u
    grf, points = [], []
    for sphere, law in zip(plant.spheres, plant.contacts, strict=True):
        transform = sym.kindyn.forward_kinematics(sphere.link, base_transform(q[:3]), q[3:])
        centre = transform[:3, 3] + transform[:3, :3] @ cs.DM(sphere.location)
        jac = cs.jacobian(centre, q)
        # planar: the link turns about +Y only, by pitch = atan2(R_02, R_00)
        dpitch = cs.jacobian(cs.atan2(transform[0, 2], transform[0, 0]), q)
        omega = cs.vertcat(0, dpitch @ v, 0)
        f, point = law.force_and_point(centre, jac @ v, angular_velocity=omega)
        # the force acts at ``point``: a point of the link moves with omega x (point - c),
        # (0, w, 0) x (d_x, d_y, d_z) = w (d_z, 0, -d_x)
        offset = point - centre
        jac_point = jac + cs.vertcat(offset[2], 0, -offset[0]) @ dpitch
        applied += jac_point.T @ f
        grf.append(f)
        points.append(point)
    r = sym.mass_matrix(q) @ a + sym.bias_force(q, v) - applied
    inputs, names = [q, v, a, act, exc, u], ["q", "v", "a", "act", "exc", "u"]
    if nc:
        inputs, names = inputs + [ft, dft], names + ["ft", "dft"]
    return cs.Function("muscle_gait_node", inputs,
                       [r, act_dot, cs.vertcat(*grf), cs.vertcat(*points), force, fibre,
                        muscle_tau, metabolic_rate, tendon], names,
                       ["r", "act_dot", "grf", "points", "force", "fibre", "muscle_tau",
                        "metabolic", "tendon"])


@functools.lru_cache(maxsize=8)
def rigid_tendon_forces(plant: MusclePlant) -> cs.Function:
    """``forces(q, v, act) -> (m,)`` N: every muscle's force with a rigid tendon.

    The initial guess of the compliant tendons' forces (their strain at F_max is 4.9 %, so
    the rigid-tendon force is near the equilibrium one).
    """
    nq, m = plant.model.nq, plant.n_muscles
    q, v, act = cs.SX.sym("q", nq), cs.SX.sym("v", nq), cs.SX.sym("act", m)
    length = plant.paths.lengths(q)
    speed = cs.jacobian(length, q) @ v
    state = plant.muscle_set.rigid_tendon(length, speed, act)
    return cs.Function("rigid_tendon_forces", [q, v, act], [state.tendon_force])
