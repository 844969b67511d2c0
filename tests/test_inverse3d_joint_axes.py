"""predgait's whole-body joint wrenches taken about OpenSim's own joints (issue 27 item 2).

Two models of subject01_walk1 give different joint moments for two reasons: the dynamics
(inertia, kinematics, the ground reaction's application) and where each model puts its
joints and axes. OpenSim 4.6 gives, per frame of its Gait2354 run, the joint centres and
axes it computed its moments about (tests/data/opensim_gait2354_reference/
opensim46_joints.sto, make_opensim46.py; from the same filtered IK as the shipped
inverse_dynamics.sto, which OpenSim 4.6 reproduces to 7e-5 N m). Taking predgait's joint
wrenches (:func:`predgait.dynamics.inverse3d.joint_wrenches`) about those joints separates
the two. Measured, t = 0.4..1.6 s (stance: vertical force > 20 N), right / left:

* subtalar: our ankle wrench about Gait2354's subtalar joint and axis gives OpenSim's
  subtalar moment, r 1.000 / 1.000, RMS 0.11 / 0.12 N m in stance: the 3D ankle dynamics
  agree. The clinical inversion moment (ISB joint coordinate system, about the floating
  axis through the model's ankle centre) does not: r -0.03 / -0.71 (stance means +1.2 /
  -7.0 N m against +13.8 / +12.0). Why, with numbers: (1) the floating axis is
  perpendicular to the shank's medio-lateral axis, which the model takes through the
  malleoli (the ISB tibia), and this subject's feet point 2.6 (r) / 8.6 (l) deg medially
  of its normal in stance (static trial: 6.9 / 11.3 deg from the markers), so that
  fraction of the 40-60 N m plantarflexion moment enters "inversion"; Gait2354 has no
  tibial torsion (its foot follows the tibia: -1.0 / +0.4 deg). Taken in OpenSim's tibia
  and foot frames and about its ankle centre, the same JCS inversion moment of our wrench
  gives r 0.965 / 0.950. (2) Our ankle centre lies 12.6 (r) / 14.0 (l) mm lateral of
  Gait2354's ankle joint (whose scaled model puts the malleolus markers' mid-point 9-10 mm
  lateral of the joint on both sides), which moves an inversion moment by the vertical
  force times that lever: about the foot's long axis r 0.88 / 0.92 at OpenSim's ankle
  centre, 0.87 / 0.57 at ours, with our foot frame within 3.7 deg of OpenSim's. So r >= 0.8
  on both sides (the test marked xfail below) needs Gait2354's ankle centre and shank
  heading, not the ISB ones this issue asked for.
* hip flexion: 0.188 / 0.181 N m/kg RMS from OpenSim; our wrench at OpenSim's hip centre
  (ours lies 27-28 mm anterior and 14-21 mm superior of it) and about its flexion axis
  0.102 / 0.094, of which the ground reaction's part 0.007: the hip centre accounts for
  half. The rest is inertial: with Gait2354's leg segments too (its thigh 9.0 kg, shank
  3.6, foot 1.5 against de Leva's 10.3, 3.1, 1.0) 0.071 / 0.062, the foot's mass most
  (0.077 / 0.072 alone); what remains is each model's kinematics (its accelerations).
* knee flexion: 0.116 / 0.261; at OpenSim's knee centre with its translation coupler
  (the tibia slides on the femur with the knee angle) 0.030 / 0.030, without the coupler
  0.050 / 0.046.
"""

from pathlib import Path

import numpy as np
import pytest

from predgait.data import read_storage, read_trc
from predgait.data.frames import OPENSIM_TO_LAB
from predgait.dynamics.inverse3d import joint_wrenches
from predgait.dynamics.inverse3d_trial import (
    clinical,
    inverse_fullbody,
    read_marker_map,
    read_trial,
)

REPO = Path(__file__).resolve().parents[1]
REFERENCE = Path(__file__).resolve().parent / "data" / "opensim_gait2354_reference"
DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_subject01_walk1"
MASS = 72.6
GRF = {"r": "ground_force_vy", "l": "1_ground_force_vy"}
MEDIAL = {"r": 1.0, "l": -1.0}   # predgait's +Y is medial on the right foot


@pytest.fixture(scope="module")
def subject01():
    if not DATA.is_dir():
        pytest.skip("shared data not available")
    markers, plates = read_trial([DATA / "subject01_walk1.trc", DATA / "subject01_walk1_grf.mot"])
    marker_map = read_marker_map(REPO / "problems" / "markers_fullbody_subject01.toml")
    result = inverse_fullbody(markers, plates, marker_map, mass=MASS, height=1.8034,
                              static=read_trc(DATA / "subject01_static.trc"))
    reference = read_storage(REFERENCE / "inverse_dynamics.sto")
    joints = read_storage(REFERENCE / "opensim46_joints.sto")
    np.testing.assert_allclose(joints.time, reference.time, atol=1e-9)
    wrenches = joint_wrenches(result.model, result.q, result.v, result.a, result.plates,
                              result.sides, [f"{j}_{s}_z" for j in ("hip", "knee", "ankle")
                                             for s in "rl"])

    def at_reference_times(values):
        return np.stack([np.interp(reference.time, result.ik.time, column)
                         for column in np.atleast_2d(values.T)], axis=-1).squeeze()

    grf = read_storage(DATA / "subject01_walk1_grf.mot")
    return {"reference": reference, "clinical": clinical(result)[1],
            "at": at_reference_times,
            "wrench": {k: tuple(at_reference_times(x) for x in v) for k, v in wrenches.items()},
            "joint": lambda name: np.stack([joints.column(f"{name}_{a}") for a in "xyz"],
                                           axis=1) @ OPENSIM_TO_LAB.T,
            "stance": {s: np.interp(reference.time, grf.time, grf.column(c)) > 20.0
                       for s, c in GRF.items()}}


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ki,ki->k", a, b)


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x ** 2)))


def about(force, moment, origin, point):
    """A wrench's moment about another point (lab frame)."""
    return moment + np.cross(origin - point, force)


@pytest.mark.parametrize("side", ["r", "l"])
def test_ankle_wrench_about_opensims_subtalar_joint_is_its_moment(subject01, side):
    force, moment, origin = subject01["wrench"][f"ankle_{side}_z"]
    joint = subject01["joint"]
    ours = dot(about(force, moment, origin, joint(f"subtalar_{side}")),
               joint(f"subtalar_{side}_axis"))
    theirs = subject01["reference"].column(f"subtalar_angle_{side}_moment")
    stance = subject01["stance"][side]
    assert np.corrcoef(ours[stance], theirs[stance])[0, 1] > 0.99
    assert rms(ours[stance] - theirs[stance]) < 1.0            # N m (measured 0.11, 0.12)
    assert np.abs(theirs[stance]).max() > 15.0                 # a moment worth comparing


@pytest.mark.parametrize("side", ["r", "l"])
def test_jcs_inversion_agrees_in_opensims_geometry(subject01, side):
    """The JCS inversion moment of our ankle wrench, with e1 Gait2354's tibia's
    medio-lateral axis and e3 its foot's vertical, about its ankle centre, correlates with
    its subtalar moment (measured 0.965 / 0.950): the inversion measure is sound, the
    geometry (below) is what differs."""
    force, moment, origin = subject01["wrench"][f"ankle_{side}_z"]
    joint = subject01["joint"]
    e1 = -joint(f"tibia_{side}_right")                        # predgait's +Y: left
    e3 = joint(f"talus_{side}_up")
    e2 = np.cross(e1, e3)
    e2 /= np.linalg.norm(e2, axis=1, keepdims=True)
    inversion = MEDIAL[side] * dot(about(force, moment, origin, joint(f"ankle_{side}")), e2)
    theirs = subject01["reference"].column(f"subtalar_angle_{side}_moment")
    stance = subject01["stance"][side]
    assert np.corrcoef(inversion[stance], theirs[stance])[0, 1] > 0.9


@pytest.mark.xfail(strict=True, reason=(
    "issue 27 item 2: the ISB floating axis is perpendicular to the transmalleolar axis, "
    "which this subject's feet point 2.6 / 8.6 deg medially of in stance, and the ankle "
    "centre lies 13-14 mm lateral of Gait2354's ankle joint: measured r -0.03 (right), "
    "-0.71 (left); see the module docstring. The like-with-like comparison, Gait2354's "
    "subtalar axis in our foot frame: tests/test_subtalar_axis.py"))
@pytest.mark.parametrize("side", ["r", "l"])
def test_clinical_inversion_moment_correlates_with_opensims_subtalar(subject01, side):
    ours = subject01["at"](subject01["clinical"][f"ankle_inversion_{side}_moment"])
    theirs = subject01["reference"].column(f"subtalar_angle_{side}_moment")
    stance = subject01["stance"][side]
    assert np.corrcoef(ours[stance], theirs[stance])[0, 1] >= 0.8


@pytest.mark.parametrize("side", ["r", "l"])
def test_hip_centre_accounts_for_half_the_hip_flexion_difference(subject01, side):
    force, moment, origin = subject01["wrench"][f"hip_{side}_z"]
    joint = subject01["joint"]
    axis = joint("pelvis_z")       # Gait2354's hip flexion axis: the pelvis' Z (to the right)
    theirs = subject01["reference"].column(f"hip_flexion_{side}_moment")
    ours = subject01["at"](subject01["clinical"][f"hip_flexion_{side}_moment"])
    at_their_centre = dot(about(force, moment, origin, joint(f"hip_{side}")), axis)
    assert rms(ours - theirs) / MASS > 0.15                    # measured 0.188 / 0.181
    assert rms(at_their_centre - theirs) / MASS < 0.11         # measured 0.102 / 0.094


@pytest.mark.parametrize("side", ["r", "l"])
def test_knee_moment_about_opensims_knee_and_coupler(subject01, side):
    force, moment, origin = subject01["wrench"][f"knee_{side}_z"]
    joint = subject01["joint"]
    # Gait2354's knee_angle (extension +): moment about the femur's Z at the tibia's
    # origin plus the force along the origin's path (the coupled translation, m/rad).
    generalised = (dot(about(force, moment, origin, joint(f"knee_{side}")),
                       joint(f"knee_{side}_axis")) + dot(force, joint(f"knee_{side}_dpdq")))
    theirs = subject01["reference"].column(f"knee_angle_{side}_moment")
    assert rms(generalised - theirs) / MASS < 0.05             # measured 0.030 / 0.030
    ours = subject01["at"](subject01["clinical"][f"knee_flexion_{side}_moment"])
    assert rms(ours + theirs) / MASS > 2 * rms(generalised - theirs) / MASS
