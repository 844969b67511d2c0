"""3D inverse dynamics of the whole body: RNEA with force plates assigned to the feet.

With the pelvis a free flyer, ``tau = RNEA(q, v, a, f_ext)`` has 6 root rows: the
wrench (pelvis frame, about the pelvis origin) that would have to act on the pelvis from
outside for the measured motion and ground reactions to agree. With perfect data it is
zero; its size shows the dynamic inconsistency of the data (model inertia, marker
kinematics, plate calibration). The other rows are the joint moments about each Cardan
axis (revolute joints ``<joint>_x/_y/_z``, N m).

Plates are assigned per stance: every contiguous run of samples with vertical force
above a threshold goes to the foot whose sole (mid-point of ``heel_contact_*`` and
``toe_contact_*``) is closest, on average, to the plate's COP during that run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.data.trial import ForcePlate
from predgait.dynamics.external import Load, assign_contacts, joint_forces
from predgait.errors import InputError
from predgait.models.loading import new_data
from predgait.models.loading3d import Model3D

FEET = ("r", "l")


def foot_points(model: Model3D, q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Lab positions of each foot's sole heel and toe per frame, side -> ((n, 3), (n, 3)) m."""
    pm, data = model.pin_model, new_data(model.pin_model)
    ids = {s: (model.frame_id(f"heel_contact_{s}"), model.frame_id(f"toe_contact_{s}"))
           for s in FEET}
    out = {s: (np.empty((q.shape[0], 3)), np.empty((q.shape[0], 3))) for s in FEET}
    for k, row in enumerate(q):
        pin.framesForwardKinematics(pm, data, row)
        for s, (heel, toe) in ids.items():
            out[s][0][k] = data.oMf[heel].translation
            out[s][1][k] = data.oMf[toe].translation
    return out


def sole_points(model: Model3D, q: np.ndarray) -> dict[str, np.ndarray]:
    """Lab position of each foot's sole mid-point per frame, side -> (n, 3) m."""
    return {s: 0.5 * (heel + toe) for s, (heel, toe) in foot_points(model, q).items()}


@dataclass(frozen=True)
class Stance:
    """One plate contact assigned to a foot.

    Attributes:
        plate: plate name.
        side: ``r`` or ``l``.
        start, stop: s (first and last loaded sample).
        distance: m, median horizontal COP distance to the chosen foot's heel-toe segment.
    """

    plate: str
    side: str
    start: float
    stop: float
    distance: float


def assign_plates(model: Model3D, q: np.ndarray, plates: Sequence[ForcePlate], *,
                  threshold: float = 20.0, max_distance: float = 0.25
                  ) -> tuple[np.ndarray, list[Stance]]:
    """Assign each plate's stances to a foot by COP proximity (:func:`assign_contacts`).

    Args:
        model: whole-body model.
        q: (n, nq) configurations at the plates' sample times (plates resampled to q).
        plates: plates at the same n times.
        threshold: N, vertical force defining contact.
        max_distance: m; a stance whose nearest sole is farther is an error.

    Returns:
        (side per plate and frame (p, n) of "r"/"l"/"" , list of stances).

    Raises:
        InputError: a plate is loaded while no foot is near its COP.
    """
    feet = foot_points(model, q)
    sides = np.full((len(plates), q.shape[0]), "", dtype="<U1")
    stances = []
    for p, plate in enumerate(plates):
        if plate.time.shape[0] != q.shape[0]:
            raise InputError(f"plate {plate.name!r} has {plate.time.shape[0]} samples but "
                             f"there are {q.shape[0]} poses; resample it to the marker times.")
        for contact in assign_contacts(plate.cop, plate.force[:, 2] > threshold, feet,
                                       reach=max_distance):
            run = contact.samples
            t0, t1 = plate.time[run.start], plate.time[run.stop - 1]
            if contact.foot is None:
                raise InputError(
                    f"plate {plate.name!r} is loaded from t = {t0:.3f} to {t1:.3f} s but no "
                    f"foot is near its COP (nearest: {contact.distance:.2f} m > "
                    f"{max_distance} m). Check the marker map, the plate corners or the lab "
                    "frame.")
            sides[p, run] = contact.foot
            stances.append(Stance(plate.name, contact.foot, float(t0), float(t1),
                                  contact.distance))
    return sides, stances


@dataclass(frozen=True, eq=False)
class InverseDynamics3D:
    """Result of :func:`inverse_dynamics_3d`.

    Attributes:
        tau: (n, nv) generalised forces: 6 pelvis rows (residual wrench, pelvis frame),
            then the joint moments per Cardan axis, N m.
        residual_force: (n, 3) N, pelvis residual force in the lab frame.
        residual_moment: (n, 3) N m, pelvis residual moment about the pelvis origin, lab.
        joint_names: names of the joint rows (tau[:, 6:]).
    """

    tau: np.ndarray
    residual_force: np.ndarray
    residual_moment: np.ndarray
    joint_names: tuple[str, ...]

    @property
    def joint_moments(self) -> dict[str, np.ndarray]:
        """Joint name -> (n,) moment about its Cardan axis, N m."""
        return {name: self.tau[:, 6 + i] for i, name in enumerate(self.joint_names)}


def _plate_loads(plates: Sequence[ForcePlate], sides: np.ndarray, k: int) -> list[Load]:
    """Frame k's plate loads on the feet they are assigned to."""
    return [Load(f"foot_{sides[p, k]}", plate.force[k], plate.cop[k], plate.free_moment[k])
            for p, plate in enumerate(plates) if sides[p, k]]


def _rnea(model: Model3D, data, q, v, a, loads: list[Load]) -> np.ndarray:
    """RNEA with the loads (frames placed in ``data`` already); fills data.f."""
    pm = model.pin_model
    if not loads:
        return pin.rnea(pm, data, q, v, a)
    return pin.rnea(pm, data, q, v, a, joint_forces(model, data, loads))


def inverse_dynamics_3d(model: Model3D, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                        plates: Sequence[ForcePlate] = (), sides: np.ndarray | None = None
                        ) -> InverseDynamics3D:
    """RNEA per frame with the plate loads on the assigned feet.

    Args:
        model: whole-body model.
        q: (n, nq) configurations.
        v: (n, nv) velocities (Pinocchio's: pelvis twist in the pelvis frame, joint rates).
        a: (n, nv) their time derivatives.
        plates: plates at the same n times (force on the foot, COP, free moment; lab).
        sides: (len(plates), n) foot per plate and frame ("r", "l" or ""), e.g. from
            :func:`assign_plates`.
    """
    pm, data = model.pin_model, new_data(model.pin_model)
    n = q.shape[0]
    if plates and sides is None:
        raise InputError("inverse_dynamics_3d: plates given without their foot assignment.")
    tau = np.empty((n, pm.nv))
    force, moment = np.empty((n, 3)), np.empty((n, 3))
    for k in range(n):
        pin.framesForwardKinematics(pm, data, q[k])
        tau[k] = _rnea(model, data, q[k], v[k], a[k], _plate_loads(plates, sides, k))
        rot = data.oMi[1].rotation
        force[k], moment[k] = rot @ tau[k, :3], rot @ tau[k, 3:6]
    return InverseDynamics3D(tau=tau, residual_force=force, residual_moment=moment,
                             joint_names=model.joint_names)


def joint_wrenches(model: Model3D, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                   plates: Sequence[ForcePlate], sides: np.ndarray, joints: Sequence[str]
                   ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The wrench each joint transmits to the body beyond it (RNEA, as :func:`inverse_dynamics_3d`).

    A joint's generalised force is this wrench's moment projected on its axis; about
    another point or axis (another model's joint centre) it gives that model's moment.

    Args:
        model: whole-body model.
        q: (n, nq) configurations.
        v: (n, nv) velocities.
        a: (n, nv) accelerations.
        plates: plates at the same n times.
        sides: (len(plates), n) foot per plate and frame (:func:`assign_plates`).
        joints: revolute joint names (e.g. ``ankle_r_z``: the ankle's wrench on the foot).

    Returns:
        joint -> (force (n, 3) N, moment about the joint's origin (n, 3) N m, that origin
        (n, 3) m), lab frame.
    """
    pm, data = model.pin_model, new_data(model.pin_model)
    ids = {name: pm.getJointId(name) for name in joints}
    out = {name: tuple(np.empty((q.shape[0], 3)) for _ in range(3)) for name in joints}
    for k in range(q.shape[0]):
        pin.framesForwardKinematics(pm, data, q[k])
        _rnea(model, data, q[k], v[k], a[k], _plate_loads(plates, sides, k))
        for name, j in ids.items():
            rot = data.oMi[j].rotation
            out[name][0][k] = rot @ data.f[j].linear
            out[name][1][k] = rot @ data.f[j].angular
            out[name][2][k] = data.oMi[j].translation
    return out


def velocities(model: Model3D, time: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocities and accelerations by central differences on the configuration manifold.

    v_k = difference(q_{k-1}, q_{k+1}) / (t_{k+1} - t_{k-1}) (one-sided at the ends);
    a is the same difference of v (component-wise, as Pinocchio's free-flyer expects).
    Filter q first (the markers or the coordinates) if the data are noisy.
    """
    pm = model.pin_model
    n = q.shape[0]
    if n < 3:
        raise InputError("inverse dynamics needs at least 3 frames.")
    v = np.empty((n, pm.nv))
    for k in range(n):
        lo, hi = max(k - 1, 0), min(k + 1, n - 1)
        v[k] = pin.difference(pm, q[lo], q[hi]) / (time[hi] - time[lo])
    a = np.gradient(v, time, axis=0)
    return v, a
