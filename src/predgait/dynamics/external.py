"""External loads (ground reaction, hip load, rod end forces) as Pinocchio forces.

A load is a force and a moment given in the lab (world) frame, acting on a segment
at a point given in the world frame. Pinocchio's ``rnea``/``aba`` take external forces
per joint, expressed in the joint's local frame at its origin; :func:`joint_forces`
does that conversion, once, for every algorithm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.data.medians import median as median_of
from predgait.models.loading import Model


@dataclass(frozen=True)
class Load:
    """A world-frame wrench on one segment.

    Attributes:
        segment: Name of the frame (segment or marker frame) the load acts on.
        force: (3,) force in the lab frame, N.
        point: (3,) point of application in the lab frame, m; ``None`` means the origin
            of the ``segment`` frame.
        moment: (3,) free moment in the lab frame, N m.
    """

    segment: str
    force: np.ndarray
    point: np.ndarray | None = None
    moment: np.ndarray | None = None


_ZERO_FORCES: dict[int, pin.StdVec_Force] = {}   # njoints -> zero forces (copied)


def _zero_forces(njoints: int) -> pin.StdVec_Force:
    """A new ``StdVec_Force`` of ``njoints`` zero forces (a copy of one kept per size)."""
    zeros = _ZERO_FORCES.get(njoints)
    if zeros is None:
        zeros = pin.StdVec_Force()
        for _ in range(njoints):
            zeros.append(pin.Force.Zero())
        _ZERO_FORCES[njoints] = zeros
    return zeros.copy()


def joint_forces(model: Model, data: pin.Data, loads: Sequence[Load]) -> pin.StdVec_Force:
    """Per-joint local forces for Pinocchio; needs ``framesForwardKinematics`` done.

    Returns:
        A ``StdVec_Force`` of length ``njoints`` (zero where nothing acts).
    """
    pm = model.pin_model
    fext = _zero_forces(pm.njoints)
    for load in loads:
        frame_id = model.frame_id(load.segment)
        joint = pm.frames[frame_id].parentJoint
        force = np.asarray(load.force, dtype=float)
        point = data.oMf[frame_id].translation if load.point is None else np.asarray(load.point)
        moment = np.zeros(3) if load.moment is None else np.asarray(load.moment, dtype=float)
        px, py, pz = point
        fx, fy, fz = force
        lever = np.array([py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx])
        world = pin.Force(force, moment + lever)  # moment about the world origin
        fext[joint] += data.oMi[joint].actInv(world)
    return fext


def generalized_load(model: Model, data: pin.Data, loads: Sequence[Load]) -> np.ndarray:
    """Generalised force (nv,) of the loads, sum of J^T w.

    Needs ``pin.computeJointJacobians`` and ``pin.updateFramePlacements`` at the current
    configuration. Equals ``rnea(q, v, a) - rnea(q, v, a, fext)``.
    """
    pm = model.pin_model
    tau = np.zeros(pm.nv)
    for load in loads:
        frame_id = model.frame_id(load.segment)
        joint = pm.frames[frame_id].parentJoint
        jac = pin.getJointJacobian(pm, data, joint, pin.ReferenceFrame.LOCAL)
        local = joint_forces(model, data, [load])[joint]
        tau += jac.T @ local.vector
    return tau


# ------------------------------------------------------------- plates to feet
def distance_to_foot(point: np.ndarray, heel: np.ndarray, toe: np.ndarray) -> np.ndarray:
    """Horizontal distance (n,) from points (n, 3) to each frame's heel-toe segment, m."""
    p, a, b = point[:, :2], heel[:, :2], toe[:, :2]
    ab = b - a
    u = np.clip(np.sum((p - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    return np.linalg.norm(p - (a + u[:, None] * ab), axis=1)


@dataclass(frozen=True)
class PlateContact:
    """One contact of a plate (a run of loaded samples) and the foot it loads.

    Attributes:
        samples: The run's samples (a slice of the plate's rows).
        foot: Key of the nearest foot in ``feet``, or None when none is within reach.
        distance: m, median horizontal COP distance to that foot's heel-toe segment.
    """

    samples: slice
    foot: str | None
    distance: float


def assign_contacts(cop: np.ndarray, loaded: np.ndarray,
                    feet: Mapping[str, tuple[np.ndarray, np.ndarray]], *, reach: float
                    ) -> list[PlateContact]:
    """THE plate-to-foot assigner: each contact of a plate goes to the nearest foot.

    Args:
        cop: (n, 3) the plate's COP, lab frame, m, at the feet's sample times.
        loaded: (n,) True where the plate is loaded (its contacts are the runs).
        feet: foot name -> (heel (n, 3), toe (n, 3)) lab positions, m.
        reach: m; a contact whose COP is farther (median) from every foot loads none.
    """
    from predgait.data.events import runs_of

    distances = {name: distance_to_foot(cop, heel, toe) for name, (heel, toe) in feet.items()}
    out = []
    for run in runs_of(loaded):
        median = {name: median_of(d[run]) for name, d in distances.items()}
        nearest = min(median, key=median.get)
        out.append(PlateContact(run, nearest if median[nearest] <= reach else None,
                                median[nearest]))
    return out
