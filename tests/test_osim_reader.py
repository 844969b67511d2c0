"""read_osim on OpenSim's 2D gait model, and one clear error for every kind of bad file.

Values are cross-checked against an independent read of the same file with ElementTree
(the reader uses expat directly), and the bundled copy against the shared original.
"""

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from predgait.errors import InputError
from predgait.models.osim import (
    JointKind,
    PointKind,
    bundled_2d_gait,
    bundled_2d_gait_path,
    read_osim,
)
from predgait.models.osim_functions import MultiplierFunction, SimmSpline

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_moco_2d_walking"
MODEL = bundled_2d_gait_path()
TEXT = MODEL.read_text()

MUSCLE_PROPERTIES = ("max_isometric_force", "optimal_fiber_length", "tendon_slack_length",
                     "pennation_angle_at_optimal", "max_contraction_velocity",
                     "activation_time_constant", "deactivation_time_constant",
                     "default_activation", "active_force_width_scale", "fiber_damping",
                     "tendon_strain_at_one_norm_force", "min_control", "max_control")


@pytest.fixture(scope="module")
def osim():
    return bundled_2d_gait()


def _line_of(text: str, needle: str, start: int = 0) -> int:
    """1-based line of the first ``needle`` at or after character ``start``."""
    index = text.index(needle, start)
    return text.count("\n", 0, index) + 1


def test_bundled_copy_is_the_shared_original():
    assert MODEL.read_bytes() == (SHARED / "2D_gait.osim").read_bytes()
    for name in ("referenceCoordinates.sto", "referenceGRF.sto", "referenceGRF.xml"):
        assert (MODEL.parent / name).read_bytes() == (SHARED / name).read_bytes()


def test_counts_and_structure(osim):
    assert len(osim.bodies) == 12
    assert len(osim.coordinates) == 10
    assert len(osim.muscles) == 18
    assert len(osim.contacts) == 4 and len(osim.spheres) == 4 and len(osim.half_spaces) == 1
    assert [a.name for a in osim.actuators] == ["lumbarAct"]
    kinds = [j.kind for j in osim.joints]
    assert kinds.count(JointKind.PLANAR) == 1 and kinds.count(JointKind.PIN) == 7
    assert kinds.count(JointKind.WELD) == 4
    assert [c.name for c in osim.joint("groundPelvis").coordinates] == [
        "pelvis_tilt", "pelvis_tx", "pelvis_ty"]
    assert osim.gravity == (0.0, -9.80665, 0.0)  # absent in the file: OpenSim's default
    # Every element's line is where it opens in the file.
    soleus = '<DeGrooteFregly2016Muscle name="soleus_r"'
    assert osim.muscle("soleus_r").line == _line_of(TEXT, soleus)
    assert osim.body("torso").line == _line_of(TEXT, '<Body name="torso"')


def test_bodies_against_the_file(osim):
    root = ET.parse(MODEL).getroot()
    bodies = {b.get("name"): b for b in root.iter("Body")}
    for body in osim.bodies:
        node = bodies[body.name]
        assert body.mass == float(node.find("mass").text)
        assert body.mass_center == tuple(float(v) for v in node.find("mass_center").text.split())
        assert body.inertia == tuple(float(v) for v in node.find("inertia").text.split())
    masses = [float(m) for m in re.findall(r"<mass>([^<]+)</mass>", TEXT)]
    assert osim.total_mass() == pytest.approx(sum(masses), rel=1e-14)
    assert osim.total_mass() == pytest.approx(62.0, abs=1e-9)


def test_muscles_against_the_file(osim):
    root = ET.parse(MODEL).getroot()
    nodes = {m.get("name"): m for m in root.iter("DeGrooteFregly2016Muscle")}
    assert set(nodes) == {m.name for m in osim.muscles}
    for muscle in osim.muscles:
        node = nodes[muscle.name]
        for key in MUSCLE_PROPERTIES:
            assert getattr(muscle, key) == float(node.find(key).text), (muscle.name, key)
        assert muscle.ignore_tendon_compliance is True
        # Absent from the file: OpenSim 4.6's defaults.
        assert muscle.passive_fiber_strain_at_one_norm_force == 0.6
        assert muscle.default_normalized_tendon_force == 0.5
        assert muscle.activation_dynamics_smoothing == 0.1
        points = node.find("GeometryPath/PathPointSet/objects")
        assert [p.name for p in muscle.path] == [p.get("name") for p in points]
        assert [p.kind.value for p in muscle.path] == [p.tag for p in points]
    ham = osim.muscle("hamstrings_r")
    assert ham.max_isometric_force == 2700 and ham.optimal_fiber_length == 0.109059287708541
    assert ham.path[0].body == "pelvis" and ham.path[0].location == (-0.121645, -0.0990559,
                                                                     0.0684676)


def test_conditional_and_moving_points(osim):
    psoas = osim.muscle("iliopsoas_r").path[2]
    assert psoas.kind is PointKind.CONDITIONAL and psoas.name == "psoas_r-P3"
    assert psoas.coordinate == "hip_flexion_r" and psoas.range == (-1.5708, 0.785398)
    rect = next(p for p in osim.muscle("rect_fem_r").path if p.kind is PointKind.MOVING)
    assert rect.body == "tibia_r" and rect.function_coordinates == ("knee_angle_r",) * 3
    fx = rect.functions[0]
    assert isinstance(fx, MultiplierFunction) and fx.scale == 0.966732152034662
    assert isinstance(fx.function, SimmSpline) and len(fx.function.x) == 17
    assert fx.function.y[0] == 0.0155805 and fx.function.x[-1] == 2.0944
    n_conditional = sum(p.kind is PointKind.CONDITIONAL for m in osim.muscles for p in m.path)
    n_moving = sum(p.kind is PointKind.MOVING for m in osim.muscles for p in m.path)
    assert (n_conditional, n_moving) == (TEXT.count("<ConditionalPathPoint "),
                                         TEXT.count("<MovingPathPoint "))


def test_joints_contacts_actuator(osim):
    hip = osim.joint("hip_r")
    assert hip.parent.body == "pelvis" and hip.child.body == "femur_r"
    assert hip.parent.translation == (-0.068277800171117897, -0.063835397331130098,
                                      0.082330694005868801)
    assert hip.coordinates[0].range == (-1.047197551196598, 2.094395102393195)
    knee = osim.coordinate("knee_angle_l")
    assert knee.range == (-2.094395102393195, 0.174532925199433) and not knee.locked
    heel = next(s for s in osim.spheres if s.name == "heel_r")
    assert heel.body == "calcn_r" and heel.radius == 0.035000000000000003
    floor = osim.half_spaces[0]
    assert floor.body == "ground" and floor.orientation == (0, 0, -1.5707963267948966)
    contact = osim.contacts[0]
    assert (contact.sphere, contact.half_space) == ("heel_r", "floor")
    assert (contact.stiffness, contact.dissipation, contact.static_friction,
            contact.dynamic_friction, contact.viscous_friction,
            contact.transition_velocity) == (3067776, 2, 0.8, 0.8, 0.5, 0.2)
    assert contact.constant_contact_force == 1e-5  # derivative_smoothing: ignored as OpenSim
    act = osim.actuators[0]
    assert (act.coordinate, act.optimal_force, act.min_control, act.max_control) == (
        "lumbar", 1.0, -150.0, 150.0)


# --- bad input: one message naming file, element, name, line, and what to do -------------

def _corrupt(tmp_path, old: str, new: str, *, start: str = "") -> tuple[Path, int]:
    """Write a copy of the model with the first ``old`` after ``start`` replaced."""
    offset = TEXT.index(start) if start else 0
    index = TEXT.index(old, offset)
    path = tmp_path / "bad_gait.osim"
    path.write_text(TEXT[:index] + new + TEXT[index + len(old):])
    return path, TEXT.count("\n", 0, index) + 1


def _set_value(tmp_path, start: str, tag: str, value: str) -> tuple[Path, int]:
    """Copy of the model with the first ``<tag>`` after ``start`` set to ``value``."""
    begin = TEXT.index(f"<{tag}>", TEXT.index(start)) + len(tag) + 2
    end = TEXT.index(f"</{tag}>", begin)
    path = tmp_path / "bad_gait.osim"
    path.write_text(TEXT[:begin] + value + TEXT[end:])
    return path, TEXT.count("\n", 0, begin) + 1


def _message(path) -> str:
    with pytest.raises(InputError) as info:
        read_osim(path)
    message = str(info.value)
    assert message.count("\n") == 0 and ";" in message  # one line: problem; what to do
    return message


def test_zero_optimal_fiber_length(tmp_path):
    path, line = _set_value(tmp_path, '<DeGrooteFregly2016Muscle name="soleus_r"',
                            "optimal_fiber_length", "0")
    msg = _message(path)
    assert f"{path}:{line}:" in msg
    assert "DeGrooteFregly2016Muscle 'soleus_r'" in msg and "optimal_fiber_length = 0" in msg
    assert "positive length" in msg


def test_negative_tendon_slack_length(tmp_path):
    path, line = _set_value(tmp_path, '<DeGrooteFregly2016Muscle name="vasti_l"',
                            "tendon_slack_length", "-0.1")
    msg = _message(path)
    assert f"{path}:{line}:" in msg and "DeGrooteFregly2016Muscle 'vasti_l'" in msg
    assert "tendon_slack_length = -" in msg and ">= 0" in msg


def test_path_point_on_missing_body(tmp_path):
    start = '<PathPoint name="bifemlh_r-P2">'
    path, _ = _corrupt(tmp_path, "/bodyset/tibia_r", "/bodyset/tibia_x", start=start)
    msg = _message(path)
    assert f"{path}:{_line_of(TEXT, start)}:" in msg and "PathPoint 'bifemlh_r-P2'" in msg
    assert "no body 'tibia_x'" in msg and "tibia_r" in msg  # lists the bodies it has


def test_joint_on_missing_frame(tmp_path):
    start = '<PinJoint name="knee_r">'
    path, _ = _corrupt(tmp_path, "<socket_parent_frame>femur_r_offset",
                       "<socket_parent_frame>femur_r_ofset", start=start)
    msg = _message(path)
    assert f"{path}:{_line_of(TEXT, start)}:" in msg and "PinJoint 'knee_r'" in msg
    assert "femur_r_ofset" in msg and "femur_r_offset" in msg


def test_offset_frame_on_missing_body(tmp_path):
    start = '<PinJoint name="ankle_l">'
    path, _ = _corrupt(tmp_path, "<socket_parent>/bodyset/tibia_l",
                       "<socket_parent>/bodyset/shin_l", start=start)
    msg = _message(path)
    frame_line = _line_of(TEXT, '<PhysicalOffsetFrame name="tibia_l_offset">',
                          TEXT.index(start))
    assert f"{path}:{frame_line}:" in msg and "PhysicalOffsetFrame 'tibia_l_offset'" in msg
    assert "no body 'shin_l'" in msg


def test_unsupported_element(tmp_path):
    text = TEXT.replace('<CoordinateActuator name="lumbarAct">',
                        '<PointActuator name="lumbarAct">', 1)
    text = text.replace("</CoordinateActuator>", "</PointActuator>", 1)
    path = tmp_path / "bad_gait.osim"
    path.write_text(text)
    msg = _message(path)
    assert f"{path}:{_line_of(TEXT, '<CoordinateActuator')}:" in msg
    assert "unsupported element <PointActuator> 'lumbarAct'" in msg and "remove it" in msg


def test_non_empty_path_wrap_set(tmp_path):
    start = '<DeGrooteFregly2016Muscle name="gastroc_l"'
    path, line = _corrupt(tmp_path, "<PathWrapSet>\n                        <objects />",
                          '<PathWrapSet>\n                        <objects><PathWrap '
                          'name="knee_wrap"/></objects>', start=start)
    msg = _message(path)
    assert f"{path}:{line + 1}:" in msg and "<PathWrap> 'knee_wrap'" in msg
    assert "DeGrooteFregly2016Muscle 'gastroc_l'" in msg


def test_unsupported_function(tmp_path):
    start = '<MovingPathPoint name="vas_int_l-P4">'
    path, line = _corrupt(tmp_path, "<SimmSpline>", "<GCVSpline>", start=start)
    text = path.read_text()
    index = text.index("</SimmSpline>", text.index(start))
    path.write_text(text[:index] + "</GCVSpline>" + text[index + len("</SimmSpline>"):])
    msg = _message(path)
    assert f"{path}:{line}:" in msg and "unsupported element <GCVSpline>" in msg


def test_conditional_point_on_missing_coordinate(tmp_path):
    start = '<ConditionalPathPoint name="psoas_r-P3">'
    path, _ = _corrupt(tmp_path, "/jointset/hip_r/hip_flexion_r", "/jointset/hip_r/hip_flex",
                       start=start)
    msg = _message(path)
    assert f"{path}:{_line_of(TEXT, start)}:" in msg
    assert "ConditionalPathPoint 'psoas_r-P3'" in msg and "hip_flex'" in msg


def test_malformed_xml_and_missing_file(tmp_path):
    path, line = _corrupt(tmp_path, "</Body>", "</Bod>", start='<Body name="femur_r">')
    with pytest.raises(InputError, match=rf"{re.escape(str(path))}:{line}: not well-formed"):
        read_osim(path)
    with pytest.raises(InputError, match="not found"):
        read_osim(tmp_path / "none.osim")


def test_duplicate_names_and_body_wrap_objects(tmp_path):
    start = '<Coordinate name="knee_angle_r">'
    path, line = _corrupt(tmp_path, start, '<Coordinate name="knee_angle_l">')
    msg = _message(path)
    assert f"{path}:{line}:" in msg and "a second Coordinate named 'knee_angle_l'" in msg
    path, line = _corrupt(tmp_path, '<ContactSphere name="front_r">',
                          '<ContactSphere name="heel_r">')
    assert f"{path}:{line}:" in _message(path)
    body = '<Body name="tibia_l">'
    path, line = _corrupt(tmp_path, body, body + '<WrapObjectSet><objects><WrapCylinder '
                          'name="knee_cyl"/></objects></WrapObjectSet>')
    msg = _message(path)
    assert f"{path}:{line}:" in msg and "<WrapCylinder> 'knee_cyl' in Body 'tibia_l'" in msg


def test_opensim_3_format(tmp_path):
    path, _ = _corrupt(tmp_path, 'Version="40000"', 'Version="30000"')
    msg = _message(path)
    assert f"{path}:2:" in msg and "Version '30000'" in msg and "save it again" in msg


def test_missing_mass_and_bad_number(tmp_path):
    path, _ = _corrupt(tmp_path, "<mass>9.7143336091723995</mass>", "")
    msg = _message(path)
    assert "Body 'pelvis'" in msg and "mass = nan" in msg
    path, line = _set_value(tmp_path, "<DeGrooteFregly2016Muscle", "max_isometric_force",
                            "2,700")
    msg = _message(path)
    assert f"{path}:{line}:" in msg and "'2,700' is not a list of numbers" in msg
    assert "DeGrooteFregly2016Muscle 'hamstrings_r' <max_isometric_force>" in msg
    assert not math.isnan(read_osim(MODEL).muscles[0].max_isometric_force)
