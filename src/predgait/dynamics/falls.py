"""When a simulated body has fallen: THE fall-limit type of the engine.

A :class:`FallLimit` lists criteria (any may be None) and turns those that apply to a
:class:`~predgait.dynamics.partitioned.PartitionedSystem` into terminal events named
``"fall: <criterion>"``; :func:`~predgait.dynamics.partitioned.simulate_partitioned`
reports the first one reached as the run's ``event`` and ``time_to_fall`` (s from the
start). Deviations are measured from a reference motion ``t -> q`` (the measured or the
kinematic run), absolute criteria from the lab.

The thesis stops the leg when it has collapsed (4.2: a segment far from upright) and
gait7 when the driven knee leaves the kinematic motion (2.4); the whole body when the
pelvis sinks or tilts, or a joint leaves the measured motion.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics.integrators import Direction, Event
from predgait.errors import InputError

#: Names of the free-flyer base's Cardan angles (X, Y, Z) in event names.
BASE_ANGLES = ("pelvis obliquity", "pelvis tilt", "pelvis rotation")


@dataclass(frozen=True)
class FallLimit:
    """Fall criteria (None: not used).

    Attributes:
        segment_angle_deg: |absolute pitch| of any segment moved by a joint of a planar
            model above this, deg (the leg's collapse).
        hip_height: Frame ``hip_center`` below this height, m.
        base_drop: The free base (pelvis, HAT) origin this far below the reference, m.
        base_angle_deg: A Cardan angle of the free-flyer base this far from the
            reference, deg.
        joint_deviation_deg: A free one-coordinate joint this far from the reference, deg.
    """

    segment_angle_deg: float | None = None
    hip_height: float | None = None
    base_drop: float | None = None
    base_angle_deg: float | None = None
    joint_deviation_deg: float | None = None

    def events(self, system, reference: Callable[[float], np.ndarray] | None = None
               ) -> list[Event]:
        """Terminal events of the criteria that apply to ``system`` (its state x).

        Args:
            system: A PartitionedSystem.
            reference: t -> (nq,) reference configuration, for the deviation criteria.

        Raises:
            InputError: A deviation criterion without a reference.
        """
        relative = (self.base_drop, self.base_angle_deg, self.joint_deviation_deg)
        if reference is None and any(v is not None for v in relative):
            raise InputError("fall limits relative to the measured motion need a reference.")
        events = []
        if self.segment_angle_deg is not None and not system.free_flyer:
            events.append(_segment_angle(system, np.radians(self.segment_angle_deg)))
        if self.hip_height is not None:
            events.append(_hip_height(system, self.hip_height))
        if self.base_drop is not None and (system.root_q or _planar_base_z(system)):
            events.append(_base_drop(system, reference, self.base_drop))
        if self.base_angle_deg is not None and system.root_free:
            events += _base_angles(system, reference, np.radians(self.base_angle_deg))
        joints = _free_joints(system)
        if self.joint_deviation_deg is not None and joints[0].size:
            events.append(_joint_deviation(system, reference, joints,
                                           np.radians(self.joint_deviation_deg)))
        return events


def _segment_angle(system, limit: float) -> Event:
    """The largest |absolute pitch| of the segments moved by the joints (planar chains)."""
    pm = system.pm
    chains = []
    for j in range(2, pm.njoints):  # joint j moves its child: pitch = base + ancestors
        rows, k = [], j
        while k > 1:
            rows.append(pm.joints[k].idx_q)
            k = pm.parents[k]
        chains.append([2, *sorted(rows)])

    def angle(t, x):
        q = system.full_state(t, x)[0]
        return max(abs(sum(q[r] for r in rows)) for rows in chains) - limit

    return Event("fall: segment angle", angle, Direction.RISING)


def _hip_height(system, height: float) -> Event:
    data, frame = system.pm.createData(), system.model.frame_id("hip_center")

    def hip(t, x):
        pin.framesForwardKinematics(system.pm, data, system.full_state(t, x)[0])
        return data.oMf[frame].translation[2] - height

    return Event("fall: hip height", hip, Direction.FALLING)


def _planar_base_z(system) -> bool:
    return not system.free_flyer and 1 in system.free.tolist()


def _base_drop(system, reference, drop: float) -> Event:
    z = 2 if system.free_flyer else 1  # q entry of the base height
    i = list(system.q_free).index(z)

    def height(t, x):
        return x[i] - reference(t)[z] + drop

    return Event("fall: base height", height, Direction.FALLING)


def pelvis_angle_error(simulated: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Pelvis Cardan X, Y, Z of ``simulated`` minus ``measured``, wrapped to +-pi, rad.

    Both are configuration rows (the simulated quaternion is renormalised).
    """
    from predgait.kinematics.ik3d import pelvis_cardan

    sim = np.concatenate([simulated[:3], simulated[3:7] / np.linalg.norm(simulated[3:7])])
    diff = pelvis_cardan(sim)[0] - pelvis_cardan(measured)[0]
    return (diff + np.pi) % (2 * np.pi) - np.pi


def _base_angles(system, reference, limit: float) -> list[Event]:
    events = []
    for axis, name in enumerate(BASE_ANGLES):
        def angle(t, x, axis=axis):
            return limit - abs(pelvis_angle_error(x[:7], reference(t))[axis])

        events.append(Event(f"fall: {name}", angle, Direction.FALLING))
    return events


def _free_joints(system) -> tuple[np.ndarray, np.ndarray]:
    """(positions in x, q entries) of the free one-coordinate joints (not the base)."""
    base_q = 7 if system.free_flyer else 3
    entries = [k for k, qi in enumerate(system.q_free) if qi >= base_q]
    return np.array(entries, dtype=int), system.q_free[entries]


def _joint_deviation(system, reference, joints, limit: float) -> Event:
    in_x, in_q = joints

    def joint(t, x):
        return limit - np.max(np.abs(x[in_x] - reference(t)[in_q]))

    return Event("fall: joint deviation", joint, Direction.FALLING)


def worst_joint(system, q: np.ndarray, reference_q: np.ndarray) -> str:
    """Name of the free joint farthest from the reference at the configuration q."""
    _, in_q = _free_joints(system)
    names = system.model.pin_model.names
    joint_of_q = {system.model.pin_model.joints[j].idx_q: names[j]
                  for j in range(1, system.model.pin_model.njoints)}
    return joint_of_q[int(in_q[np.argmax(np.abs(q[in_q] - reference_q[in_q]))])]
