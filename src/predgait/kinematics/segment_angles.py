"""Segment angle, angular velocity and acceleration from two markers (thesis 3.2.2).

For a segment marked by a lower target b and an upper target a, ``R = a - b``. All
quantities are in the sagittal plane, about +Y (positive: the top tilts toward +X).

* Angle (3.2.1-3.2.4): x_hat = R x J / |R x J| lies in the plane, across the segment,
  and Theta = asin(x_hat . K); within 45 deg of +-90 deg the thesis switches to
  Theta = +-(90 deg - asin(z_hat . K)) with z_hat = R/|R| in the plane.
* Angular velocity (3.2.5-3.2.7): V_a/b = omega x R gives omega = V_x / R_z (3.2.6) or
  omega = -V_z / R_x (3.2.7); 3.2.6 is used while |Theta| < 45 deg, 3.2.7 otherwise
  (thesis section 4.1, Fig. 4.1.5).
* Angular acceleration (3.2.8-3.2.10): A_a/b = alpha x R + omega x (omega x R) gives
  alpha = (A_x + omega^2 R_x) / R_z (3.2.9) or alpha = -(A_z + omega^2 R_z) / R_x. The
  thesis prints 3.2.10 as (-A_z + omega^2 R_z)/R_x; expanding 3.2.8 about +Y gives the
  sign used here (a test checks it on an exactly rotating rigid body).
* Rigid-body corrections (3.2.11-3.2.17): the components of V_a/b and of
  A_a/b - omega x (omega x R) along the segment are removed before use.
"""

from __future__ import annotations

import numpy as np

SWITCH = np.radians(45.0)


def _planar(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return v[..., 0], v[..., 2]


def segment_angle(upper: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Theta (n,), rad, of the segment from ``lower`` to ``upper`` (n, 3), eqs. 3.2.1-3.2.4."""
    rx, rz = _planar(upper - lower)
    norm = np.hypot(rx, rz)
    across_k = rx / norm          # x_hat . K with x_hat = (-R_z, 0, R_x)/|R_xz|
    along_k = rz / norm           # z_hat . K
    theta = np.arcsin(np.clip(across_k, -1, 1))
    near_pos = (np.abs(theta - np.pi / 2) < SWITCH) & (rx > 0)
    near_neg = (np.abs(theta + np.pi / 2) < SWITCH) & (rx < 0)
    theta = np.where(near_pos, np.pi / 2 - np.arcsin(np.clip(along_k, -1, 1)), theta)
    return np.where(near_neg, -np.pi / 2 + np.arcsin(np.clip(along_k, -1, 1)), theta)


def _remove_along(v: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Vector v minus its component along r, in the plane (3.2.11-3.2.12, 3.2.15-3.2.16)."""
    vx, vz = v
    rx, rz = r
    along = (vx * rx + vz * rz) / (rx**2 + rz**2)
    return vx - along * rx, vz - along * rz


def angular_velocity(upper: np.ndarray, lower: np.ndarray, v_upper: np.ndarray,
                     v_lower: np.ndarray, *, rigid_correction: bool = True) -> np.ndarray:
    """Omega (n,), rad/s, from marker positions and velocities (n, 3), eqs. 3.2.5-3.2.7."""
    r = _planar(upper - lower)
    v = _planar(v_upper - v_lower)
    if rigid_correction:
        v = _remove_along(v, r)
    theta = segment_angle(upper, lower)
    with np.errstate(divide="ignore", invalid="ignore"):
        omega_x = v[0] / r[1]
        omega_z = -v[1] / r[0]
    return np.where(np.abs(theta) < SWITCH, omega_x, omega_z)


def angular_acceleration(upper: np.ndarray, lower: np.ndarray, a_upper: np.ndarray,
                         a_lower: np.ndarray, omega: np.ndarray, *,
                         rigid_correction: bool = True) -> np.ndarray:
    """Alpha (n,), rad/s^2, from marker accelerations (n, 3) and omega, eqs. 3.2.8-3.2.10."""
    r = _planar(upper - lower)
    a = _planar(a_upper - a_lower)
    w2 = omega**2
    if rigid_correction:
        tangential = (a[0] + w2 * r[0], a[1] + w2 * r[1])   # A - omega x (omega x R)
        tangential = _remove_along(tangential, r)
        a = (tangential[0] - w2 * r[0], tangential[1] - w2 * r[1])
    theta = segment_angle(upper, lower)
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha_x = (a[0] + w2 * r[0]) / r[1]
        alpha_z = -(a[1] + w2 * r[1]) / r[0]
    return np.where(np.abs(theta) < SWITCH, alpha_x, alpha_z)
