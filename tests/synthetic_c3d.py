"""Small synthetic C3D files written with ezc3d, for the reader tests (no downloaded data).

``write_c3d`` writes markers (any length unit, any axes) and force plates of TYPE 2, 3 or 4
with the raw channels a lab's amplifier would record, so the tests know the answer: the
wrench put in, in newtons and metres, before any plate convention was applied.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PlateSpec:
    """One plate: TYPE, its channels (k, n_channels) in analog units, corners, origin."""

    kind: int
    channels: np.ndarray
    corners: np.ndarray  # (4, 3) in the point unit, file frame
    origin: tuple[float, float, float]
    cal_matrix: np.ndarray | None = None  # (6, 6) for TYPE 4
    units: tuple[str, ...] = ()


@dataclass(frozen=True)
class C3DSpec:
    """Markers (n, m, 3) in ``unit`` and plates sampled ``ratio`` times per frame.

    ``analog_scale`` is written as ANALOG:SCALE: ezc3d stores the channels divided by it and
    multiplies them back when reading, so a reader that ignored or doubled it would fail.
    """

    xyz: np.ndarray
    names: tuple[str, ...]
    rate: float = 100.0
    unit: str = "mm"
    ratio: int = 10
    plates: tuple[PlateSpec, ...] = ()
    analog_scale: float = 1.0


def _int_parameter(c3d, group: str, name: str, value: np.ndarray) -> None:
    """Add an INTEGER parameter (ezc3d's add_parameter stores integer arrays as floats)."""
    import ezc3d

    parameter = ezc3d.ezc3d.Parameter(name, "")
    flat = [int(v) for v in value.reshape(-1, order="F")]
    parameter.set(ezc3d.ezc3d.VecInt(flat), list(value.shape))
    c3d._storage["parameters"].add_parameter(group, parameter)


def write_c3d(path, spec: C3DSpec):
    """Write ``spec`` as a C3D file at ``path`` (float format); returns the path."""
    import ezc3d

    c3d = ezc3d.c3d()
    n, m = spec.xyz.shape[:2]
    points = np.ones((4, m, n))
    points[:3] = np.transpose(spec.xyz, (2, 1, 0))
    c3d["parameters"]["POINT"]["RATE"]["value"] = [spec.rate]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = list(spec.names)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = [spec.unit]
    c3d["data"]["points"] = points
    if spec.plates:
        channels = np.concatenate([p.channels for p in spec.plates], axis=1)  # (k, c)
        c3d["parameters"]["ANALOG"]["RATE"]["value"] = [spec.rate * spec.ratio]
        c3d["parameters"]["ANALOG"]["LABELS"]["value"] = [
            f"ch{i + 1}" for i in range(channels.shape[1])]
        c3d["parameters"]["ANALOG"]["SCALE"]["value"] = [spec.analog_scale] * channels.shape[1]
        units = [u for p in spec.plates for u in (p.units or ("N",) * 3 + ("Nmm",) * 3)]
        c3d["parameters"]["ANALOG"]["UNITS"]["value"] = units
        c3d["data"]["analogs"] = channels.T[None, :, :]
        width = max(p.channels.shape[1] for p in spec.plates)
        chan = np.zeros((width, len(spec.plates)), dtype=int)
        start = 1
        for j, p in enumerate(spec.plates):
            chan[: p.channels.shape[1], j] = np.arange(start, start + p.channels.shape[1])
            start += p.channels.shape[1]
        _int_parameter(c3d, "FORCE_PLATFORM", "USED", np.array([len(spec.plates)]))
        _int_parameter(c3d, "FORCE_PLATFORM", "TYPE", np.array([p.kind for p in spec.plates]))
        _int_parameter(c3d, "FORCE_PLATFORM", "ZERO", np.array([1, 0]))
        c3d.add_parameter("FORCE_PLATFORM", "CORNERS", np.stack(
            [np.asarray(p.corners, dtype=float).T for p in spec.plates], axis=2))
        c3d.add_parameter("FORCE_PLATFORM", "ORIGIN", np.array(
            [p.origin for p in spec.plates], dtype=float).T)
        _int_parameter(c3d, "FORCE_PLATFORM", "CHANNEL", chan)
        cals = [p.cal_matrix for p in spec.plates if p.cal_matrix is not None]
        if cals:
            c3d.add_parameter("FORCE_PLATFORM", "CAL_MATRIX", np.stack(
                [np.eye(6) if p.cal_matrix is None else p.cal_matrix for p in spec.plates],
                axis=2))
    c3d.write(str(path))
    return path
