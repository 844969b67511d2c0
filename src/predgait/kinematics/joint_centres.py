"""Joint centres from skin markers: hip by regression, knee and ankle by static calibration.

* Hip: Harrington et al. (2007), J Biomech 40:595-602, regression on pelvis width PW
  (inter-ASIS distance) and depth PD (mid-ASIS to mid-PSIS/sacrum), in the pelvis frame
  (origin mid-ASIS, x anterior, y superior, z to the side of the hip), mm:
  x = -0.24 PD - 9.9, y = -0.30 PW - 10.9, z = 0.33 PW + 7.3.
* Knee and ankle: the midpoint of the medial and lateral markers (epicondyles,
  malleoli) in a static trial, stored in the frame of a three-marker cluster on the
  segment (thigh, shank) and rebuilt from that cluster in each walking frame (the
  calibrated anatomical systems technique, Cappozzo et al. 1995, Clin Biomech 10:171).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.data.events import Side
from predgait.data.trial import Markers
from predgait.errors import InputError


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def cluster_frame(p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Origin (..., 3) and rotation (..., 3, 3) of a frame built on three markers."""
    x = _unit(p2 - p1)
    z = _unit(np.cross(x, p3 - p1))
    y = np.cross(z, x)
    return p1, np.stack([x, y, z], axis=-1)


def harrington_hip(rasis: np.ndarray, lasis: np.ndarray, sacrum: np.ndarray, *,
                   side: Side) -> np.ndarray:
    """Hip joint centre (..., 3), m, lab frame, by Harrington et al. (2007)."""
    mid_asis = 0.5 * (rasis + lasis)
    lateral = _unit(rasis - lasis)  # toward the right
    anterior = mid_asis - sacrum
    anterior = _unit(anterior - np.sum(anterior * lateral, axis=-1, keepdims=True) * lateral)
    superior = np.cross(lateral, anterior)
    width = np.linalg.norm(rasis - lasis, axis=-1, keepdims=True) * 1000.0
    depth = np.linalg.norm(mid_asis - sacrum, axis=-1, keepdims=True) * 1000.0
    sign = 1.0 if side == Side.RIGHT else -1.0
    local_mm = (-0.24 * depth - 9.9, -0.30 * width - 10.9, sign * (0.33 * width + 7.3))
    return mid_asis + (local_mm[0] * anterior + local_mm[1] * superior
                       + local_mm[2] * lateral) / 1000.0


@dataclass(frozen=True)
class ClusterCentre:
    """A joint centre fixed in a three-marker cluster, from a static trial.

    Attributes:
        name: Joint centre name (``knee_center``, ``ankle_center``).
        cluster: Names of the three cluster markers.
        local: (3,) position in the cluster frame, m.
    """

    name: str
    cluster: tuple[str, str, str]
    local: np.ndarray

    def locate(self, markers: Markers) -> np.ndarray:
        """The centre (n, 3) in each frame of a (walking) trial, lab frame."""
        origin, rotation = cluster_frame(*(markers.get(n) for n in self.cluster))
        return origin + np.einsum("nij,j->ni", rotation, self.local)


def calibrate_centre(static: Markers, name: str, medial: str, lateral: str,
                     cluster: tuple[str, str, str]) -> ClusterCentre:
    """Mid-point of two static markers expressed in a cluster frame (averaged over frames)."""
    mean = {n: np.nanmean(static.get(n), axis=0) for n in (medial, lateral, *cluster)}
    for n, value in mean.items():
        if not np.all(np.isfinite(value)):
            raise InputError(f"{static.source}: marker {n} has no valid frame in the static "
                             "trial.")
    origin, rotation = cluster_frame(*(mean[n] for n in cluster))
    centre = 0.5 * (mean[medial] + mean[lateral])
    return ClusterCentre(name, tuple(cluster), rotation.T @ (centre - origin))
