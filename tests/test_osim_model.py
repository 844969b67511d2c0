"""build_model on OpenSim's 2D gait model: Pinocchio = ADAM, and Pinocchio = OpenSim.

OpenSim's own body frames, sphere centres and model COM at 6 poses come from
tests/reference/osim2d/model_frames.csv (written once by OpenSim 4.6 with
make_reference.py there). A wrong axis mapping, joint sign or base sign moves them.
"""

import csv
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from predgait.errors import InputError
from predgait.models.osim import PointKind, bundled_2d_gait, bundled_2d_gait_path
from predgait.models.osim_model import build_model
from predgait.models.symbolic import symbolic_model

REFERENCE = Path(__file__).resolve().parent / "reference" / "osim2d"
FRAMES = REFERENCE / "model_frames.csv"
#: 2D_gait.osim with turned and shifted offset frames and products of inertia, saved by
#: OpenSim 4.6, with its body frames and both models' kinetic energy (make_body_frames.py).
OFFSETS = REFERENCE / "offsets_2d_gait.osim"
TEXT = bundled_2d_gait_path().read_text()
#: OpenSim (X forward, Y up, Z right) -> predgait lab (X forward, Y left, Z up), written out
#: here rather than imported, so that a wrong mapping in the code cannot hide.
LAB = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
COORDINATES = ("pelvis_tilt", "pelvis_tx", "pelvis_ty", "hip_flexion_l", "hip_flexion_r",
               "knee_angle_l", "knee_angle_r", "ankle_angle_l", "ankle_angle_r", "lumbar")


@pytest.fixture(scope="module")
def built():
    return build_model(bundled_2d_gait())


def _rows(path: Path) -> list[dict]:
    with path.open() as handle:
        return list(csv.DictReader(handle))


def _poses():
    with FRAMES.open() as handle:
        rows = list(csv.DictReader(handle))
    poses: dict[int, list[dict]] = {}
    for row in rows:
        poses.setdefault(int(row["pose"]), []).append(row)
    return poses


def test_coordinates_kind_and_limits(built):
    model = built.model
    assert model.kind == "osim2d" and model.nq == 10
    assert model.gravity == 9.80665
    assert built.osim_coordinates[:3] == ("pelvis_tx", "pelvis_ty", "pelvis_tilt")
    assert set(built.osim_coordinates) == set(COORDINATES)
    assert model.joint_names == built.osim_coordinates[3:]  # joints named as coordinates
    pm = model.pin_model
    for i, name in enumerate(model.joint_names):
        low, high = built.osim.coordinate(name).range
        assert (pm.lowerPositionLimit[3 + i], pm.upperPositionLimit[3 + i]) == (low, high)
    values = dict(zip(COORDINATES, np.linspace(-0.4, 0.5, 10), strict=True))
    q = built.q_from_osim(values)
    assert q[0] == values["pelvis_tx"] and q[2] == -values["pelvis_tilt"]
    back = built.osim_from_q(q)
    assert all(back[n] == pytest.approx(v, abs=0) for n, v in values.items())
    rows = built.q_from_osim({n: np.full(4, v) for n, v in values.items()})
    assert rows.shape == (4, 10) and np.array_equal(rows[2], q)
    with pytest.raises(InputError, match="no value for coordinate.*lumbar"):
        built.q_from_osim({n: v for n, v in values.items() if n != "lumbar"})
    assert np.array_equal(built.default_q(), np.zeros(10))  # the file's defaults: all 0
    assert built.state_path("knee_angle_r", "speed") == "/jointset/knee_r/knee_angle_r/speed"
    degrees = {built.state_path(n): np.rad2deg(v) if n not in ("pelvis_tx", "pelvis_ty")
               else v for n, v in values.items()}
    assert np.allclose(built.q_from_table(degrees, in_degrees=True), q, rtol=1e-15, atol=0)
    speeds = built.table_from_q(q, quantity="speed")
    assert list(speeds)[2] == "/jointset/groundPelvis/pelvis_tilt/speed"
    with pytest.raises(InputError, match="no column '/jointset/lumbar/lumbar/speed'"):
        built.q_from_table({k: v for k, v in speeds.items() if "lumbar" not in k},
                           quantity="speed")


def test_total_mass_is_the_files(built):
    masses = [float(m) for m in re.findall(r"<mass>([^<]+)</mass>", TEXT)]
    assert len(masses) == 12
    assert built.model.total_mass() == pytest.approx(sum(masses), rel=1e-13)


def test_adam_equals_pinocchio(built):
    model = built.model
    sym = symbolic_model(model)
    pm = model.pin_model
    data = pm.createData()
    rng = np.random.default_rng(26)
    for _ in range(3):
        q = rng.uniform(-0.8, 0.8, model.nq)
        v = rng.uniform(-2.0, 2.0, model.nq)
        mass = pin.crba(pm, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        bias = pin.rnea(pm, data, q, v, np.zeros(model.nq))
        assert np.abs(np.array(sym.mass_matrix(q)) - mass).max() < 1e-9
        assert np.abs(np.array(sym.bias_force(q, v)).ravel() - bias).max() < 1e-9
        pin.framesForwardKinematics(pm, data, q)
        for body in ("toes_r", "torso"):
            expected = data.oMf[pm.getFrameId(built.body_link(body))].translation
            got = np.array(sym.frame_position(built.body_link(body))(q)).ravel()
            assert np.abs(got - expected).max() < 1e-9


def test_body_frames_sphere_centres_and_com_match_opensim(built):
    model = built.model
    pm = model.pin_model
    data = pm.createData()
    poses = _poses()
    assert len(poses) == 6
    checked = 0
    for rows in poses.values():
        values = {n: float(rows[0][n]) for n in COORDINATES}
        q = built.q_from_osim(values)
        pin.framesForwardKinematics(pm, data, q)
        for row in rows:
            expected = LAB @ np.array([float(row[k]) for k in ("x", "y", "z")])
            if row["kind"] == "model":
                com = pin.centerOfMass(pm, data, q)
                assert np.abs(com - expected).max() < 1e-9
                assert float(row["mass"]) == pytest.approx(model.total_mass(), rel=1e-10)
                continue
            if row["kind"] == "body":
                body, location = row["name"], np.zeros(3)
            else:
                sphere = next(s for s in built.osim.spheres if s.name == row["name"])
                body, location = sphere.body, np.array(sphere.location)
            link, point = built.point_on_body(body, location)
            placement = data.oMf[pm.getFrameId(link)]
            assert np.abs(placement.act(point) - expected).max() < 1e-9, row["name"]
            if row["kind"] == "body":
                rotation = np.array([float(row[f"r{i}{j}"]) for i in range(3)
                                     for j in range(3)]).reshape(3, 3)
                got = placement.rotation @ built.rotation_to_link(body)
                assert np.abs(got - LAB @ rotation).max() < 1e-9, row["name"]
            checked += 1
    assert checked == 6 * 16


def test_offset_frames_match_opensim():
    built = build_model(OFFSETS)
    pm = built.model.pin_model
    data = pm.createData()
    rows = _rows(REFERENCE / "offsets_frames.csv")
    assert len(rows) == 5 * 12
    for row in rows:
        q = built.q_from_osim({n: float(row[n]) for n in COORDINATES})
        pin.framesForwardKinematics(pm, data, q)
        body = built.osim.body(row["name"])
        placement = data.oMf[pm.getFrameId(built.body_link(body.name))]
        for point, keys in ((np.zeros(3), ("x", "y", "z")),
                            (np.array(body.mass_center), ("com_x", "com_y", "com_z"))):
            expected = LAB @ np.array([float(row[k]) for k in keys])
            got = placement.act(built.point_on_body(body.name, point)[1])
            assert np.abs(got - expected).max() < 1e-9, (row["pose"], body.name)
        rotation = np.array([float(row[f"r{i}{j}"]) for i in range(3)
                             for j in range(3)]).reshape(3, 3)
        got = placement.rotation @ built.rotation_to_link(body.name)
        assert np.abs(got - LAB @ rotation).max() < 1e-9, (row["pose"], body.name)


def test_kinetic_energy_matches_opensim(built):
    """0.5 v^T M v = OpenSim's kinetic energy for random v: the whole planar mass matrix.

    (Only a body's OpenSim Izz, predgait's Iyy, enters it: products of inertia and the
    in-plane moments act out of the plane, where the planar root holds the model.)
    """
    models = {"original": built, "offsets": build_model(OFFSETS)}
    rows = _rows(REFERENCE / "kinetic_energy.csv")
    assert len(rows) == 2 * 15
    for row in rows:
        model = models[row["model"]]
        q = model.q_from_osim({n: float(row[n]) for n in COORDINATES})
        v = model.q_from_osim({n: float(row[f"{n}.speed"]) for n in COORDINATES})
        mass = pin.crba(model.model.pin_model, model.model.pin_model.createData(), q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        energy = float(row["kinetic_energy"])
        assert 0.5 * v @ mass @ v == pytest.approx(energy, rel=1e-10, abs=1e-10)


def test_a_file_opensim_wrote_reads_the_same():
    """OpenSim 4.6's own print of the model (format 40600) reads to the same elements."""
    original, printed = bundled_2d_gait(), build_model(OFFSETS).osim
    strip = lambda items: [{k: v for k, v in vars(i).items() if k != "line"} for i in items]  # noqa: E731
    for name in ("muscles", "actuators", "spheres", "half_spaces", "contacts"):
        a, b = strip(getattr(original, name)), strip(getattr(printed, name))
        if name == "muscles":  # path points carry lines; a moving point's legacy
            for muscle in a + b:  # location is not written by OpenSim 4.6
                muscle["path"] = [{k: v for k, v in vars(p).items() if k != "line" and
                                   (k != "location" or p.kind is not PointKind.MOVING)}
                                  for p in muscle["path"]]
        assert a == b, name
    changed = {"torso", "talus_r"}
    assert strip(b for b in original.bodies if b.name not in changed) == \
        strip(b for b in printed.bodies if b.name not in changed)


# --- models build_model refuses -------------------------------------------------------

def _copy(tmp_path, old: str, new: str, *, start: str = "") -> Path:
    index = TEXT.index(old, TEXT.index(start) if start else 0)
    path = tmp_path / "bad_gait.osim"
    path.write_text(TEXT[:index] + new + TEXT[index + len(old):])
    return path


def test_non_planar_offset_frame(tmp_path):
    start = '<PinJoint name="knee_l">'
    path = _copy(tmp_path, "<orientation>0 0 0", "<orientation>0.1 0 0", start=start)
    line = TEXT.count("\n", 0, TEXT.index('<PhysicalOffsetFrame name="femur_l_offset">',
                                          TEXT.index(start))) + 1
    with pytest.raises(InputError) as info:
        build_model(path)
    msg = str(info.value)
    assert f"{path}:{line}:" in msg and "PhysicalOffsetFrame 'femur_l_offset'" in msg
    assert "PinJoint 'knee_l'" in msg and "about Z alone" in msg


def test_locked_coordinate(tmp_path):
    start = '<Coordinate name="knee_angle_r">'
    path = _copy(tmp_path, start, start + "<locked>true</locked>")
    with pytest.raises(InputError, match=rf":{TEXT.count(chr(10), 0, TEXT.index(start)) + 1}: "
                       r"Coordinate 'knee_angle_r' is locked; unlock it"):
        build_model(path)


def test_second_joint_to_ground(tmp_path):
    start = '<PinJoint name="lumbar">'
    path = _copy(tmp_path, "<socket_parent>/bodyset/pelvis", "<socket_parent>/ground",
                 start=start)
    with pytest.raises(InputError, match="exactly one joint to ground, a PlanarJoint; found "
                       "PlanarJoint 'groundPelvis', PinJoint 'lumbar'"):
        build_model(path)


def test_reference_motion_stands_on_the_floor(built):
    """Moco's tracking reference through the model: in every frame the lowest contact
    sphere is 0-3 cm into the floor (z = 0), and every foot carrying over 200 N (its
    referenceGRF) presses a sphere into it. (Feet carrying under 5 N are not always clear:
    at the left toe-off the reference's toe sphere is 15 mm deep with 0.4 N.)"""
    from predgait.data.bundled import bundled_path
    from predgait.data.storage import read_storage

    coordinates = read_storage(bundled_path("moco_2d_walking/referenceCoordinates.sto"))
    grf = read_storage(bundled_path("moco_2d_walking/referenceGRF.sto"))
    q = built.q_from_table(coordinates.columns)
    assert q.shape == (50, 10) and np.array_equal(
        q[:, 0], coordinates.columns["/jointset/groundPelvis/pelvis_tx/value"])
    assert np.array_equal(built.q_from_table(built.table_from_q(q)), q)
    assert np.array_equal(grf.time, coordinates.time)
    pm = built.model.pin_model
    data = pm.createData()
    loaded = 0
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(pm, data, qk)
        clearance = {"r": [], "l": []}
        for sphere in built.osim.spheres:
            link, point = built.point_on_body(sphere.body, sphere.location)
            clearance[sphere.body[-1]].append(data.oMf[pm.getFrameId(link)].act(point)[2]
                                              - sphere.radius)
        assert -0.03 < min(min(c) for c in clearance.values()) < 0.0, k
        for side, values in clearance.items():
            if grf.columns[f"ground_force_{side}_vy"][k] > 200.0:
                assert min(values) < 0.0, (k, side)
                loaded += 1
    assert loaded > 40


def test_model_show_prints_the_opensim_model(capsys):
    from predgait.cli import main
    from predgait.models.osim import bundled_2d_gait_path

    assert main(["model", "show", str(bundled_2d_gait_path())]) == 0
    out = capsys.readouterr().out
    assert "total mass 62.000 kg; 10 coordinates, 18 muscles, 4 contacts" in out
    assert "knee_angle_r        -120.0 ..   10.0 deg" in out
    assert "soleus_r" in out
