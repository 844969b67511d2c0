"""Files as other labs and vendors write them: known answers on small synthetic files.

Each case reproduces one format feature met in public files of other labs (BTS: a Y-up
lab with ORIGIN z < 0; Kistler: TYPE 3 plates; AMTI with a calibration matrix: TYPE 4;
plates-only or X-up exports; OpenSim's Rajagopal data: padded TRC headers and
``ground_force_r_vx`` columns), with the wrench, COP and marker positions put in known, so
the reader must give them back in the lab frame (X forward, Y left, Z up; m, N, N m).
"""

import logging
from pathlib import Path

import numpy as np
import pytest

from predgait.data import read_c3d, read_grf_mot, read_trc
from predgait.data.storage import read_external_loads
from predgait.errors import InputError
from synthetic_c3d import C3DSpec, PlateSpec, write_c3d

N_FRAMES = 30


def body(up: int = 2, travel: float = 1000.0) -> np.ndarray:
    """Four markers (mm) of a body walking ``travel`` mm along file +X, ``up`` = vertical axis."""
    xyz = np.zeros((N_FRAMES, 4, 3))
    heights = [1700.0, 900.0, 50.0, 50.0]
    lateral = [0.0, 100.0, 100.0, 100.0]
    forward = [0.0, 50.0, -50.0, 150.0]
    side = 3 - up if up in (1, 2) else 1  # the remaining horizontal axis
    for j in range(4):
        xyz[:, j, 0] = forward[j] + np.linspace(0.0, travel, N_FRAMES)
        xyz[:, j, up] = heights[j]
        xyz[:, j, side] = lateral[j]
    return xyz


NAMES = ("HEAD", "HIP", "HEEL", "TOE")


def corners_about(centre, x_axis, y_axis, half=(250.0, 200.0)) -> np.ndarray:
    """C3D corner order (quadrants +x+y, -x+y, -x-y, +x-y) of a plate, file frame (mm)."""
    c, x, y = (np.asarray(v, dtype=float) for v in (centre, x_axis, y_axis))
    hx, hy = half
    return np.array([c + hx * x + hy * y, c - hx * x + hy * y, c - hx * x - hy * y,
                     c + hx * x - hy * y])


def sensor_channels(force_p, cop_p, tz_p, sensor) -> np.ndarray:
    """Six channels (N, N mm) of the wrench on the foot about the sensor origin.

    ``force_p`` N, ``cop_p`` mm from the surface centre, ``tz_p`` N mm, ``sensor`` = sensor
    origin minus surface centre (mm), all in the plate frame (z down into the plate).
    """
    moment = np.cross(np.asarray(cop_p) - np.asarray(sensor), force_p) + [0.0, 0.0, tz_p]
    return np.tile(np.concatenate([force_p, moment]), (N_FRAMES * 10, 1))


@pytest.mark.parametrize("origin_sign", [1.0, -1.0])
def test_y_up_lab_type2_plate_gives_lab_wrench(tmp_path, origin_sign):
    # BTS writes a Y-up lab; the plate lies in the XZ plane, its z axis (into it) is -Y.
    x_p, y_p, z_p = np.eye(3)[0], np.eye(3)[2], -np.eye(3)[1]
    rot = np.column_stack([x_p, y_p, z_p])  # plate -> file
    centre = np.array([500.0, 0.0, 200.0])
    force_file = np.array([80.0, 700.0, -30.0])  # on the foot, N: up is file +Y
    cop_file = np.array([560.0, 0.0, 150.0])  # mm
    tz_file = np.array([0.0, 4000.0, 0.0])  # N mm about the vertical
    sensor = np.array([2.0, -1.0, 40.0])  # sensor origin 40 mm below the surface
    channels = sensor_channels(rot.T @ force_file, rot.T @ (cop_file - centre),
                               (rot.T @ tz_file)[2], sensor)
    plate = PlateSpec(2, channels, corners_about(centre, x_p, y_p),
                      tuple(origin_sign * sensor))  # vendors write either sign
    path = write_c3d(tmp_path / "yup.c3d", C3DSpec(xyz=body(up=1), names=NAMES, plates=(plate,),
                                                   analog_scale=0.5))
    trial = read_c3d(path)

    def to_lab(v):  # Y-up, walking along +X: lab = (x, -z, y)
        return np.array([v[0], -v[2], v[1]])

    p = trial.plates[0]
    np.testing.assert_allclose(p.force, np.tile(to_lab(force_file), (len(p.time), 1)), atol=1e-3)
    np.testing.assert_allclose(p.cop[5], to_lab(cop_file) / 1000.0, atol=1e-6)
    np.testing.assert_allclose(p.free_moment[5], to_lab(tz_file) / 1000.0, atol=1e-6)
    np.testing.assert_allclose(trial.markers.get("HEAD")[0], [0.0, 0.0, 1.7], atol=1e-9)
    np.testing.assert_allclose(np.diff(p.time), 1e-3)  # plates at their own (analog) rate
    assert trial.markers.rate == 100.0


def test_type4_calibration_matrix_is_applied(tmp_path):
    # AMTI-style TYPE 4: the channels are volts-like values; CAL_MATRIX turns them into the
    # wrench. Z-up lab, plate x = +Y, plate y = +X (z = -Z, into the floor).
    x_p, y_p = np.eye(3)[1], np.eye(3)[0]
    centre = np.array([300.0, 250.0, 0.0])
    force_p = np.array([-20.0, 60.0, -650.0])  # plate frame: the foot is pushed up (-z)
    wrench = sensor_channels(force_p, [30.0, -40.0, 0.0], 1500.0, [0.0, 0.0, 35.0])[0]
    rng = np.random.default_rng(3)
    cal = np.diag([300.0, 300.0, 800.0, 9e4, 9e4, 4e4]) + rng.normal(0.0, 20.0, (6, 6))
    volts = np.linalg.solve(cal, wrench)
    plate = PlateSpec(4, np.tile(volts, (N_FRAMES * 10, 1)), corners_about(centre, x_p, y_p),
                      (0.0, 0.0, -35.0), cal_matrix=cal)
    trial = read_c3d(write_c3d(tmp_path / "t4.c3d", C3DSpec(xyz=body(), names=NAMES,
                                                            plates=(plate,))))
    p = trial.plates[0]
    rot = np.column_stack([x_p, y_p, np.cross(x_p, y_p)])
    np.testing.assert_allclose(p.force[0], rot @ force_p, rtol=1e-5)  # (60, -20, 650) N
    assert p.force[0, 2] == pytest.approx(650.0, rel=1e-5)
    np.testing.assert_allclose(p.cop[0], (centre + rot @ [30.0, -40.0, 0.0]) / 1000.0,
                               atol=1e-6)
    np.testing.assert_allclose(p.free_moment[0], [0.0, 0.0, -1.5], atol=1e-5)


def kistler_channels(force_p, cop_p, tz_p, a, b, depth) -> np.ndarray:
    """Eight Kistler channels (N) for a wrench (plate frame; COP mm; Tz N mm)."""
    moment = np.cross(np.asarray(cop_p) - [0.0, 0.0, depth], force_p) + [0.0, 0.0, tz_p]
    fx, fy, fz = force_p
    # fz1..fz4 from Fz, Mx = b (fz1 + fz2 - fz3 - fz4), My = a (fz2 + fz3 - fz1 - fz4)
    rows = np.array([[1, 1, 1, 1], [b, b, -b, -b], [-a, a, a, -a]], dtype=float)
    fz_sensors = np.linalg.lstsq(rows, [fz, moment[0], moment[1]], rcond=None)[0]
    dx = moment[2] / b  # Mz = b (fx34 - fx12) with fy14 = fy23
    values = [(fx - dx) / 2, (fx + dx) / 2, fy / 2, fy / 2, *fz_sensors]
    return np.tile(values, (N_FRAMES * 10, 1))


def test_kistler_type3_plate(tmp_path):
    x_p, y_p = np.eye(3)[0], -np.eye(3)[1]  # z = x cross (-y) = -Z: into the floor
    centre = np.array([400.0, 300.0, 0.0])
    force_p = np.array([45.0, 25.0, -720.0])
    cop_p = np.array([-60.0, 35.0, 0.0])
    channels = kistler_channels(force_p, cop_p, -2500.0, a=210.0, b=260.0, depth=41.0)
    plate = PlateSpec(3, channels, corners_about(centre, x_p, y_p), (210.0, 260.0, -41.0),
                      units=("N",) * 8)
    trial = read_c3d(write_c3d(tmp_path / "k.c3d", C3DSpec(xyz=body(), names=NAMES,
                                                           plates=(plate,))))
    p = trial.plates[0]
    rot = np.column_stack([x_p, y_p, np.cross(x_p, y_p)])
    np.testing.assert_allclose(p.force[0], rot @ force_p, atol=1e-3)
    np.testing.assert_allclose(p.cop[0], (centre + rot @ cop_p) / 1000.0, atol=1e-6)
    np.testing.assert_allclose(p.free_moment[0], [0.0, 0.0, 2.5], atol=1e-4)


def test_force_on_the_plate_is_negated(tmp_path, caplog):
    x_p, y_p = np.eye(3)[1], np.eye(3)[0]
    force_p = np.array([0.0, 0.0, 700.0])  # a file storing the force ON THE PLATE (down)
    channels = sensor_channels(force_p, [0.0, 0.0, 0.0], 0.0, [0.0, 0.0, 40.0])
    plate = PlateSpec(2, channels, corners_about([300.0, 250.0, 0.0], x_p, y_p), (0, 0, 40.0))
    with caplog.at_level(logging.WARNING):
        trial = read_c3d(write_c3d(tmp_path / "down.c3d", C3DSpec(xyz=body(), names=NAMES,
                                                                  plates=(plate,))))
    assert trial.plates[0].force[0, 2] == pytest.approx(700.0)
    assert "force on the plate" in caplog.text


def test_c3d_markers_at_zero_are_missing(tmp_path):
    xyz = body()
    xyz[7, 2] = 0.0  # a writer storing a missing marker as zeros with residual 0
    markers = read_c3d(write_c3d(tmp_path / "gap.c3d", C3DSpec(xyz=xyz, names=NAMES))).markers
    assert np.isnan(markers.get("HEEL")[7]).all()
    assert np.isfinite(markers.get("HEEL")[[6, 8]]).all()


def test_more_than_255_markers_use_labels2(tmp_path):
    xyz = np.concatenate([body()] + [body() + 10.0 * k for k in range(1, 75)], axis=1)
    names = tuple(f"M{i}" for i in range(xyz.shape[1]))  # 300: LABELS holds 255, LABELS2 45
    markers = read_c3d(write_c3d(tmp_path / "many.c3d", C3DSpec(xyz=xyz, names=names))).markers
    assert markers.names == names
    np.testing.assert_allclose(markers.get("M299")[0], (xyz[0, 299] - [0, 0, 0]) / 1000.0)


def test_wrong_length_unit_is_refused(tmp_path):
    leg = body(travel=300.0)[:, 1:]  # hip, heel, toe: 0.85 m tall, in mm
    with pytest.raises(InputError, match=r"span 850 m .* check the length unit POINT:UNITS 'm'"):
        read_c3d(write_c3d(tmp_path / "m.c3d", C3DSpec(xyz=leg, names=NAMES[1:], unit="m")))
    with pytest.raises(InputError, match=r"span 0.00165 m .* POINT:UNITS 'mm'"):
        read_c3d(write_c3d(tmp_path / "mm.c3d", C3DSpec(xyz=body() / 1000.0, names=NAMES)))


def test_unusable_c3d_files_fail_loudly(tmp_path):
    no_markers = C3DSpec(xyz=np.zeros((N_FRAMES, 0, 3)), names=())
    with pytest.raises(InputError, match="no marker data"):
        read_c3d(write_c3d(tmp_path / "plates_only.c3d", no_markers))
    # An X-up export without plates (Optotrak): Z-up is assumed and refused.
    x_up = body(up=2)[:, :, [2, 1, 0]]
    with pytest.raises(InputError, match=r"x_up\.c3d: read as Z-up .* vertical axis"):
        read_c3d(write_c3d(tmp_path / "x_up.c3d", C3DSpec(xyz=x_up, names=NAMES)))
    x_p, y_p = np.eye(3)[1], np.eye(3)[0]
    channels = sensor_channels([0.0, 0.0, -700.0], [0.0, 0.0, 0.0], 0.0, [0.0, 0.0, 40.0])
    odd = PlateSpec(5, channels, corners_about([300.0, 250.0, 0.0], x_p, y_p), (0, 0, 40.0))
    with pytest.raises(InputError, match="TYPE of plate 1 is 5; predgait reads types 1 to 4"):
        read_c3d(write_c3d(tmp_path / "t5.c3d", C3DSpec(xyz=body(), names=NAMES,
                                                        plates=(odd,))))
    flat = PlateSpec(2, channels, np.zeros((4, 3)), (0, 0, 40.0))
    with pytest.raises(InputError, match="CORNERS of plate 1 do not span a surface"):
        read_c3d(write_c3d(tmp_path / "flat.c3d", C3DSpec(xyz=body(), names=NAMES,
                                                          plates=(flat,))))


TRC_PADDED = """PathFileType  4\t(X/Y/Z) C:\\\\data\\\\walk.trc
DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames
  100.0\t\t  100.0\t\t    {n}\t\t     3\t\t mm\t  100.0\t      1\t    {n}
Frame#\tTime\tHEAD\t\t\tHEEL\t\t\tTOE\t\t\t
\t\tX1\tY1\tZ1\tX2\tY2\tZ2\tX3\tY3\tZ3
"""


def _trc(path, rows, n=N_FRAMES):
    text = TRC_PADDED.format(n=n) + "\n".join(
        "\t".join([str(i + 1), f"{i / 100:.2f}", *(f"{v:.3f}" for v in row)])
        for i, row in enumerate(rows)) + "\n"
    path.write_text(text)
    return path


def test_trc_with_padded_header_reads_in_metres(tmp_path):
    # Rajagopal's TRC pads the header line with double tabs; OpenSim TRCs are Y-up.
    rows = [[10.0 * i, 1700.0, 0.0, 10.0 * i - 50, 50.0, 100.0, 10.0 * i + 150, 50.0, 100.0]
            for i in range(N_FRAMES)]
    rows[4][6:9] = [0.0, 0.0, 0.0]  # Hamner's TRC writes a missing marker as zeros
    markers = read_trc(_trc(tmp_path / "walk.trc", rows))
    assert markers.rate == 100.0
    np.testing.assert_allclose(markers.get("HEEL")[1], [-0.04, -0.1, 0.05], atol=1e-12)
    assert np.isnan(markers.get("TOE")[4]).all() and not np.isnan(markers.get("TOE")[5]).any()


def test_trc_in_mm_declared_m_is_refused(tmp_path):
    rows = [[10.0 * i, 900.0, 0.0, 10.0 * i - 50, 50.0, 100.0, 10.0 * i + 150, 50.0, 100.0]
            for i in range(N_FRAMES)]
    path = _trc(tmp_path / "walk.trc", rows)
    path.write_text(path.read_text().replace("\t mm\t", "\t m\t"))
    with pytest.raises(InputError, match=r"walk\.trc: the markers span 850 m .* Units 'm'"):
        read_trc(path)


def test_z_up_trc_is_refused(tmp_path):
    rows = [[10.0 * i, 0.0, 1700.0, 10.0 * i - 50, 100.0, 50.0, 10.0 * i + 150, 100.0, 50.0]
            for i in range(N_FRAMES)]
    with pytest.raises(InputError, match=r"zup\.trc: read as axes 'opensim'.*vertical axis"):
        read_trc(_trc(tmp_path / "zup.trc", rows))


def test_mot_with_side_infix_columns_and_external_loads(tmp_path):
    # OpenSim's Rajagopal data: ground_force_r_vx ... named by the ExternalLoads XML.
    labels = ["time"] + [f"{stem}{a}" for side in "rl" for stem in (
        f"ground_force_{side}_v", f"ground_force_{side}_p", f"ground_torque_{side}_")
        for a in "xyz"]
    rows = [[t, 50.0, 700.0, -10.0, 0.3, 0.0, 0.1, 0.0, 2.0, 0.0,
             0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0] for t in (0.0, 0.001, 0.002)]
    header = "grf\nversion=1\nnRows=3\nnColumns=19\ninDegrees=no\nendheader\n"
    text = header + "\t".join(labels) + "\n" + "\n".join(
        "\t".join(f"{v:g}" for v in row) for row in rows) + "\n"
    mot = tmp_path / "grf_walk.mot"
    mot.write_text(text)
    xml = tmp_path / "grf_walk.xml"
    xml.write_text("<OpenSimDocument><ExternalLoads>" + "".join(
        f'<ExternalForce name="{name}"><force_identifier>ground_force_{s}_v'
        f"</force_identifier></ExternalForce>" for name, s in (("right", "r"), ("left", "l")))
        + "</ExternalLoads></OpenSimDocument>")
    plates = read_grf_mot(mot, names=read_external_loads(xml))
    assert [p.name for p in plates] == ["right", "left"]
    right = plates[0]  # OpenSim Y-up: lab = (x, -z, y)
    np.testing.assert_allclose(right.force[0], [50.0, 10.0, 700.0])
    np.testing.assert_allclose(right.cop[0], [0.3, -0.1, 0.0])
    np.testing.assert_allclose(right.free_moment[0], [0.0, 0.0, 2.0])
    # The same columns written Z-up (vertical force in the z column) are refused.
    z_up = [row[:2] + [row[3], row[2]] + row[4:] for row in rows]
    mot.write_text(header + "\t".join(labels) + "\n" + "\n".join(
        "\t".join(f"{v:g}" for v in row) for row in z_up) + "\n")
    with pytest.raises(InputError, match=r"grf_walk\.mot: plate r's force peaks at 702 N "
                                         r"horizontally but 10 N vertically"):
        read_grf_mot(mot)


def test_grf_cop_in_mm_is_named_in_the_error(tmp_path):
    # A lab's MOT with the COP in mm (OpenSim expects m): the plates then lie hundreds of
    # metres from the foot, and the error says so instead of only "no contact".
    from predgait.dynamics.inverse_options import bundled_options, with_options
    from predgait.dynamics.inverse_trial import run_inverse

    options = bundled_options()
    lines = options.grf.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader") + 1
    labels = lines[start].split("\t")
    cop = [j for j, label in enumerate(labels) if "force_p" in label]
    rows = []
    for line in lines[start + 1:]:
        values = line.split("\t")
        for j in cop:
            values[j] = f"{float(values[j]) * 1000.0:.6g}"
        rows.append("\t".join(values))
    mot = tmp_path / "grf_mm.mot"
    mot.write_text("\n".join(lines[: start + 1] + rows) + "\n")
    with pytest.raises(InputError, match=r"grf_mm\.mot: no plate .* COP lies \d+ m from the heel"):
        run_inverse(with_options(options, grf=mot))


WALKING5 = Path(__file__).resolve().parents[2] / "shared" / "data" / "opensim_walking5_c3d" / \
    "walking5.c3d"


def test_walking5_written_y_up_with_the_other_origin_sign_reads_the_same(tmp_path):
    # The real trial as a Y-up lab (BTS-like) whose plates' ORIGIN has the other sign.
    import ezc3d

    c3d = ezc3d.c3d(str(WALKING5))
    to_y_up = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    points = c3d["data"]["points"]
    points[:3] = np.einsum("ij,jmn->imn", to_y_up, points[:3])
    c3d["data"]["points"] = points
    plates = c3d["parameters"]["FORCE_PLATFORM"]
    plates["CORNERS"]["value"] = np.einsum("ij,jkp->ikp", to_y_up,
                                           np.asarray(plates["CORNERS"]["value"], dtype=float))
    plates["ORIGIN"]["value"] = -np.asarray(plates["ORIGIN"]["value"], dtype=float)
    c3d.write(str(tmp_path / "walking5_y_up.c3d"))
    original, turned = read_c3d(WALKING5), read_c3d(tmp_path / "walking5_y_up.c3d")
    np.testing.assert_allclose(turned.markers.xyz, original.markers.xyz, atol=1e-6)
    for a, b in zip(original.plates, turned.plates, strict=True):
        np.testing.assert_allclose(b.force, a.force, atol=1e-6)
        np.testing.assert_allclose(b.cop, a.cop, atol=1e-6)
        np.testing.assert_allclose(b.free_moment, a.free_moment, atol=1e-6)


def test_a_trial_too_short_says_so(tmp_path):
    from predgait.dynamics.inverse_options import InverseOptions
    from predgait.dynamics.inverse_trial import run_inverse

    path = write_c3d(tmp_path / "two.c3d", C3DSpec(xyz=body()[:2], names=NAMES))
    points = {"hip": "HIP", "knee": "HIP", "ankle": "HEEL", "heel": "HEEL", "toe": "TOE"}
    with pytest.raises(InputError, match=r"two\.c3d: the trial has 2 frames; inverse dynamics "
                                         r"needs at least 20"):
        run_inverse(InverseOptions(markers=path, mass=70.0, height=1.75, points=points))


def test_moment_units_that_put_the_cop_off_the_plate_are_refused(tmp_path):
    # walking5's moments are N mm; labelled N m, its COP would lie metres off the plates.
    import ezc3d

    c3d = ezc3d.c3d(str(WALKING5))
    units = list(c3d["parameters"]["ANALOG"]["UNITS"]["value"])
    c3d["parameters"]["ANALOG"]["UNITS"]["value"] = ["Nm" if u == "Nmm" else u for u in units]
    c3d.write(str(tmp_path / "nm.c3d"))
    with pytest.raises(InputError, match=r"nm\.c3d: plate 1 \(TYPE 2\): the centre of pressure "
                                         r"lies .* beyond the plate's edge .* ANALOG:UNITS"):
        read_c3d(tmp_path / "nm.c3d")


def test_type1_plate_with_cop_channels(tmp_path):
    # TYPE 1: Fx, Fy, Fz, COPx, COPy (from the surface centre) and Tz, plate frame.
    x_p, y_p = np.eye(3)[1], np.eye(3)[0]
    centre = np.array([300.0, 250.0, 0.0])
    values = [15.0, -40.0, -690.0, 70.0, -20.0, 1200.0]  # N, N, N, mm, mm, N mm
    plate = PlateSpec(1, np.tile(values, (N_FRAMES * 10, 1)), corners_about(centre, x_p, y_p),
                      (0.0, 0.0, 0.0), units=("N", "N", "N", "mm", "mm", "Nmm"))
    p = read_c3d(write_c3d(tmp_path / "t1.c3d", C3DSpec(xyz=body(), names=NAMES,
                                                        plates=(plate,)))).plates[0]
    rot = np.column_stack([x_p, y_p, np.cross(x_p, y_p)])  # plate z = -Z
    np.testing.assert_allclose(p.force[0], rot @ values[:3], atol=1e-4)  # (-40, 15, 690)
    np.testing.assert_allclose(p.cop[0], (centre + rot @ [70.0, -20.0, 0.0]) / 1000.0,
                               atol=1e-6)
    np.testing.assert_allclose(p.free_moment[0], [0.0, 0.0, -1.2], atol=1e-6)


def test_csv_markers_in_mm_read_as_m_are_refused(tmp_path):
    from predgait.data import read_markers_csv

    xyz = body(travel=300.0)[:, 1:]  # hip, heel, toe in mm, Z-up
    header = "time," + ",".join(f"{n}_{a}" for n in NAMES[1:] for a in "xyz")
    path = tmp_path / "walk.csv"
    path.write_text(header + "\n" + "\n".join(
        ",".join([f"{i / 100:.2f}", *(f"{v:.3f}" for v in frame.ravel())])
        for i, frame in enumerate(xyz)) + "\n")
    columns = {n: (f"{n}_x", f"{n}_y", f"{n}_z") for n in NAMES[1:]}
    with pytest.raises(InputError, match=r"walk\.csv: the markers span 850 m .* units 'm'"):
        read_markers_csv(path, columns)
    heel = read_markers_csv(path, columns, units="mm").get("HEEL")[0]
    np.testing.assert_allclose(heel, [-0.05, 0.1, 0.05])


def test_vicon_subject_prefixed_labels_are_found_by_their_bare_name():
    from predgait.data.trial import Markers

    xyz = np.zeros((2, 3, 3))
    xyz[:, 1] = 1.0
    markers = Markers(time=[0.0, 0.01], names=("Daphnee:RASI", "Daphnee:LASI", "Other:LASI"),
                      xyz=xyz, rate=100.0, source="vicon.c3d")
    np.testing.assert_allclose(markers.get("Daphnee:LASI")[0], 1.0)
    np.testing.assert_allclose(markers.get("RASI")[0], 0.0)
    with pytest.raises(InputError, match="vicon.c3d: no marker named 'LASI'"):
        markers.get("LASI")  # two subjects have it: ambiguous
