"""SmoothSphereHalfSpaceForce (dynamics.smooth_contact) against OpenSim 4.6 and known limits.

The reference, tests/reference/osim2d/contact_force.csv, is OpenSim's own force on each of
2D_gait.osim's four contact spheres at 824 states (make_reference.py, peer Python); frames
map as p_predgait = (x, -z, y)_opensim, a proper rotation, so forces, torques and angular
velocities map the same way.
"""

from __future__ import annotations

import csv
from pathlib import Path
from types import SimpleNamespace

import casadi as cs
import numpy as np
import pytest

from predgait.dynamics.smooth_contact import SmoothSphereContact, contacts_from_osim
from predgait.errors import InputError

REFERENCE = Path(__file__).resolve().parent / "reference" / "osim2d"
OSIM_TO_LAB = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
TEXT = {"force", "body", "kind", "sphere"}


def _table(name: str) -> dict[str, np.ndarray]:
    with (REFERENCE / name).open() as handle:
        rows = list(csv.DictReader(handle))
    return {key: np.array([r[key] if key in TEXT else float(r[key]) for r in rows])
            for key in rows[0]}


def _lab(table, prefix: str, names=("x", "y", "z")) -> np.ndarray:
    osim = np.stack([table[f"{prefix}{n}"] for n in names], axis=-1)
    return osim @ OSIM_TO_LAB.T


def _laws() -> dict[str, SmoothSphereContact]:
    params = _table("contact_parameters.csv")
    laws = {}
    for i, name in enumerate(params["force"]):
        record = SimpleNamespace(**{key: values[i] for key, values in params.items()})
        laws[name] = SmoothSphereContact.from_osim(record, radius=float(params["radius"][i]))
    return laws


MOCO_HEEL = SmoothSphereContact(
    radius=0.035, stiffness=3067776.0, dissipation=2.0, static_friction=0.8,
    dynamic_friction=0.8, viscous_friction=0.5, transition_velocity=0.2)


@pytest.mark.parametrize("kind", ["translation", "rotation"])
def test_force_and_torque_match_opensim(kind):
    table, laws = _table("contact_force.csv"), _laws()
    assert set(laws) == set(table["force"]) and len(laws) == 4
    worst_force = worst_torque = 0.0
    for name, law in laws.items():
        rows = (table["force"] == name) & (table["kind"] == kind)
        sub = {key: values[rows] for key, values in table.items()}
        assert len(sub["force"]) >= 24
        center, velocity = _lab(sub, "center_"), _lab(sub, "center_v")
        omega = _lab(sub, "omega_")
        if kind == "translation":
            assert np.all(omega == 0.0)
        else:
            assert np.all(np.abs(omega[:, 1]) > 0.01)   # rolling about lab +-Y
        np.testing.assert_allclose(law.radius - center[:, 2], sub["penetration"], atol=1e-12)
        force, point = law.force_and_point(center, velocity, angular_velocity=omega)
        expected = _lab(sub, "force_")
        scale = np.linalg.norm(expected, axis=1, keepdims=True)
        err = np.abs(force - expected) / np.maximum(scale, 1e-3)
        worst_force = max(worst_force, err.max())
        # OpenSim's torque is about the sphere body's origin: it locates the contact point.
        lever = point - _lab(sub, "origin_")
        torque, expected_torque = np.cross(lever, force), _lab(sub, "torque_")
        tscale = np.linalg.norm(lever, axis=1, keepdims=True) * np.maximum(scale, 1e-3)
        worst_torque = max(worst_torque, (np.abs(torque - expected_torque) / tscale).max())
    assert worst_force < 1e-6
    assert worst_torque < 1e-6


def test_reference_spans_the_regimes():
    """The table covers -1..2 cm, both normal-speed signs, slip on both sides of v_t."""
    table = _table("contact_force.csv")
    depth, rate, slip = table["penetration"], -table["center_vy"], table["center_vx"]
    assert depth.min() == pytest.approx(-0.01) and depth.max() == pytest.approx(0.02)
    assert rate.min() < -2.0 / 3.0 / 2.0 < 0.0 < rate.max()
    for sign in (-1.0, 1.0):
        assert np.any(sign * slip > 0.2) and np.any((sign * slip > 0.0) & (sign * slip < 0.2))


def test_casadi_equals_numpy_and_symbolic_parameters():
    table, law = _table("contact_force.csv"), _laws()["contactFront_r"]
    c, v, w, e = cs.SX.sym("c", 3), cs.SX.sym("v", 3), cs.SX.sym("w", 3), cs.SX.sym("E")
    symbolic = SmoothSphereContact(**{**law.__dict__, "stiffness": e})
    force, point = symbolic.force_and_point(c, v, angular_velocity=w)
    jac = cs.jacobian(force, cs.vertcat(c, v))
    fun = cs.Function("contact", [c, v, w, e], [force, point, jac])
    rows = np.flatnonzero(table["force"] == "contactFront_r")[::7]
    sub = {key: values[rows] for key, values in table.items()}
    center, velocity, omega = _lab(sub, "center_"), _lab(sub, "center_v"), _lab(sub, "omega_")
    f_np, p_np = law.force_and_point(center, velocity, angular_velocity=omega)
    for i in range(len(rows)):
        f_cs, p_cs, jac = fun(center[i], velocity[i], omega[i], law.stiffness)
        np.testing.assert_allclose(f_cs.full().ravel(), f_np[i], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(p_cs.full().ravel(), p_np[i], rtol=1e-12, atol=1e-15)
        assert np.all(np.isfinite(jac.full()))


def test_no_force_far_above_the_floor_and_monotone_in_depth():
    heights = np.array([0.05, 0.1, 1.0])
    center = np.stack([0 * heights, 0 * heights, MOCO_HEEL.radius + heights], axis=-1)
    force, _ = MOCO_HEEL.force_and_point(center, np.array([0.3, -0.1, -0.2]))
    assert np.abs(force).max() < 1e-6
    depth = np.linspace(-0.01, 0.02, 301)
    normal = MOCO_HEEL.normal_force(depth, 0.0)
    assert np.all(np.diff(normal) > 0.0)


def test_hertz_force_of_a_sphere_on_a_plane():
    """Static, sharp smoothing: F = 4/3 k^(3/2) sqrt(R) d^(3/2), k = E^(2/3) / 2."""
    law = SmoothSphereContact(radius=0.035, stiffness=3067776.0, constant_contact_force=1e-14,
                              hertz_smoothing=1e4)
    depth = np.array([0.002, 0.005, 0.01, 0.02])
    k = 0.5 * law.stiffness ** (2.0 / 3.0)
    hertz = 4.0 / 3.0 * k**1.5 * np.sqrt(law.radius) * depth**1.5
    np.testing.assert_allclose(law.normal_force(depth, 0.0), hertz, rtol=1e-6)
    # The Moco example's own law at larger depth (tanh -> 1): F / (d^2 + cf)^(3/4) constant,
    # that constant Hertz's; cf = 1e-5 m^2 still shifts d^(3/2) by 1.4 % between 2 and 4 cm.
    depth = np.array([0.02, 0.03, 0.04])
    k = 0.5 * MOCO_HEEL.stiffness ** (2.0 / 3.0)
    scaled = MOCO_HEEL.normal_force(depth, 0.0) / (depth**2 + 1e-5) ** 0.75
    np.testing.assert_allclose(scaled, 4.0 / 3.0 * k**1.5 * np.sqrt(0.035), rtol=1e-5)


def test_hunt_crossley_dissipation_and_lift_off():
    depth, c = 0.01, MOCO_HEEL.dissipation
    static = MOCO_HEEL.normal_force(depth, 0.0)
    for rate in (0.5, 0.1, -0.1, -0.2):
        ratio = MOCO_HEEL.normal_force(depth, rate) / static
        assert ratio == pytest.approx(1.0 + 1.5 * c * rate, rel=1e-5)
    assert abs(MOCO_HEEL.normal_force(depth, -1.0)) < 1e-12 * static
    elastic = SmoothSphereContact(**{**MOCO_HEEL.__dict__, "dissipation": 0.0})
    for rate in (-1.0, 0.0, 2.0):
        assert elastic.normal_force(depth, rate) == pytest.approx(static, rel=1e-12)


def test_friction_opposes_slip_with_stribeck_peak_at_transition():
    law = SmoothSphereContact(radius=0.02, stiffness=2e6, dissipation=1.0, static_friction=1.0,
                              dynamic_friction=0.6, viscous_friction=0.1,
                              transition_velocity=0.2, constant_contact_force=1e-14)
    rng = np.random.default_rng(3)
    angle = rng.uniform(0.0, 2.0 * np.pi, 40)
    speed = np.concatenate([[0.2, 2.0, 0.001], rng.uniform(0.01, 3.0, 37)])
    slip = np.stack([speed * np.cos(angle), speed * np.sin(angle), 0.0 * speed], axis=-1)
    center = np.array([0.4, -0.1, law.radius - 0.008])
    force, _ = law.force_and_point(center, slip)
    tangential = force[:, :2]
    cosine = np.sum(tangential * slip[:, :2], axis=1) / (
        np.linalg.norm(tangential, axis=1) * speed)
    np.testing.assert_allclose(cosine, -1.0, atol=1e-12)
    mu = np.linalg.norm(tangential, axis=1) / force[:, 2]
    assert mu[0] == pytest.approx(1.0 + 0.1 * 0.2, rel=1e-9)          # mu_s + mu_v v_t
    assert mu[1] == pytest.approx(0.6 + 2 * 0.4 / 101 + 0.1 * 2.0, rel=1e-9)
    assert mu[2] == pytest.approx(0.005 * (0.6 + 0.8 / (1 + 0.005**2)) + 1e-4, rel=1e-9)


def test_contact_point_midway_and_rolling_without_slip():
    depth, speed = 0.006, 1.3
    center = np.array([0.7, 0.05, MOCO_HEEL.radius - depth])
    drop = MOCO_HEEL.radius - depth / 2
    omega = np.array([0.0, speed / drop, 0.0])     # rolling forward about +Y
    force, point = MOCO_HEEL.force_and_point(center, np.array([speed, 0, 0]),
                                             angular_velocity=omega)
    np.testing.assert_allclose(point, [0.7, 0.05, -depth / 2], atol=1e-15)
    assert force[2] == pytest.approx(MOCO_HEEL.normal_force(depth, 0.0), rel=1e-12)
    assert abs(force[0]) < 1e-9 * force[2] and force[1] == 0.0
    sliding, _ = MOCO_HEEL.force_and_point(center, np.array([speed, 0, 0]))
    assert sliding[0] < -0.8 * sliding[2]


@pytest.mark.parametrize(("key", "value"), [("stiffness", -1.0), ("transition_velocity", 0.0),
                                            ("radius", float("nan")), ("dissipation", -2.0)])
def test_impossible_parameters_are_refused(key, value):
    kwargs = {**MOCO_HEEL.__dict__, key: value}
    with pytest.raises(InputError, match=key):
        SmoothSphereContact(**kwargs)


def test_laws_from_the_read_model_are_opensims(tmp_path):
    from predgait.models.osim import bundled_2d_gait, bundled_2d_gait_path, read_osim

    osim = bundled_2d_gait()
    laws = contacts_from_osim(osim)
    params = _table("contact_parameters.csv")
    reference = _laws()
    assert [c.name for c in osim.contacts] == list(params["force"])
    for contact, law in zip(osim.contacts, laws, strict=True):
        assert law == reference[contact.name]
    tilted = bundled_2d_gait_path().read_text().replace(
        "<orientation>0 0 -1.5707963267948966</orientation>", "<orientation>0 0 -1.4</orientation>")
    path = tmp_path / "tilted.osim"
    path.write_text(tilted)
    with pytest.raises(InputError, match=r"tilted.osim: line \d+: ContactHalfSpace 'floor'"):
        contacts_from_osim(read_osim(path))
    text = bundled_2d_gait_path().read_text()
    start = text.index('<SmoothSphereHalfSpaceForce name="contactFront_r">')
    stalled = text[:start] + text[start:].replace(
        "<transition_velocity>0.20000000000000001</transition_velocity>",
        "<transition_velocity>0</transition_velocity>", 1)
    path = tmp_path / "stalled.osim"
    path.write_text(stalled)
    with pytest.raises(InputError, match=r"stalled.osim: line 50: SmoothSphereHalfSpaceForce "
                       r"'contactFront_r': .*transition_velocity = 0.0"):
        contacts_from_osim(read_osim(path))


def _gait():
    table = _table("gait_contact.csv")
    assert len(table["time"]) == 101
    return table


def test_gait_states_of_mocos_tracking_solution():
    """OpenSim's forces along Moco's example2DWalking gait, from OpenSim's sphere kinematics."""
    table, laws = _gait(), _laws()
    peak = max(np.abs(table[f"{n}.force_y"]).max() for n in laws)
    assert peak > 300.0                                   # a loaded stance, not a swing
    rolling_effect = 0.0
    for name, law in laws.items():
        center, velocity = _lab(table, f"{name}.center_"), _lab(table, f"{name}.center_v")
        omega, expected = _lab(table, f"{name}.omega_"), _lab(table, f"{name}.force_")
        force, _ = law.force_and_point(center, velocity, angular_velocity=omega)
        np.testing.assert_allclose(force, expected, rtol=0, atol=1e-6 * peak)
        centre_only, _ = law.force_and_point(center, velocity)
        rolling_effect = max(rolling_effect, np.abs(centre_only - expected).max() / peak)
    assert rolling_effect > 0.05           # the contact point's slip matters along a gait


def test_gait_forces_from_the_predgait_model():
    """The same forces with sphere kinematics from the predgait model of 2D_gait.osim."""
    import pinocchio as pin

    from predgait.models.osim import bundled_2d_gait
    from predgait.models.osim_model import build_model

    table, built = _gait(), build_model(bundled_2d_gait())
    model, laws = built.model.pin_model, contacts_from_osim(built.osim)
    data = model.createData()
    spheres = {s.name: s for s in built.osim.spheres}
    names = built.osim_coordinates
    q = built.q_from_osim({n: table[n] for n in names})
    v = built.q_from_osim({n: table[f"{n}.speed"] for n in names})
    peak = max(np.abs(table[f"{c.name}.force_y"]).max() for c in built.osim.contacts)
    frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for contact, law in zip(built.osim.contacts, laws, strict=True):
        sphere = spheres[contact.sphere]
        link, location = built.point_on_body(sphere.body, sphere.location)
        fid = model.getFrameId(link)
        forces = []
        for k in range(len(q)):
            pin.forwardKinematics(model, data, q[k], v[k])
            pin.updateFramePlacements(model, data)
            placement = data.oMf[fid]
            center = placement.act(location)
            twist = pin.getFrameVelocity(model, data, fid, frame)
            offset = placement.rotation @ location
            velocity = twist.linear + np.cross(twist.angular, offset)
            force, _ = law.force_and_point(center, velocity, angular_velocity=twist.angular)
            forces.append(force)
        expected = _lab(table, f"{contact.name}.force_")
        np.testing.assert_allclose(np.array(forces), expected, rtol=0, atol=1e-6 * peak)
