"""Trial containers: marker trajectories and force plates in the lab frame.

All arrays are SI (m, N, N m, s) and expressed in the lab frame: X forward (direction
of progression), Y lateral (left), Z up. Readers convert units and axes at the file
boundary (see :mod:`predgait.data.frames`), so everything past a reader is in this form.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from predgait.errors import InputError


def _as_float(array, name: str) -> np.ndarray:
    out = np.asarray(array, dtype=float)
    out.setflags(write=False)
    return out


def uniform_time(time, rate: float, *, source: str = "", tolerance: float = 0.25) -> np.ndarray:
    """Rebuild a uniform time base from a file's rate, checking it against its time column.

    Files often print time with few decimals (the subject01 TRC at 60 Hz reads steps of
    0.016/0.017 s). The uniform base ``t0 + arange(n) / rate`` replaces such a column.

    Args:
        time: (n,) s, the time column as read.
        rate: Hz, the sample rate stated by the file.
        source: file name used in error messages.
        tolerance: largest allowed deviation, in sample periods.

    Returns:
        (n,) s, uniform time starting at ``time[0]``.

    Raises:
        InputError: if the column deviates from the uniform base by more than
            ``tolerance / rate`` (dropped frames or a wrong rate).
    """
    time = np.asarray(time, dtype=float)
    if not rate > 0:
        raise InputError(f"{source}: the sample rate is {rate!r} Hz; it must be positive.")
    uniform = time[0] + np.arange(time.size) / rate
    bad = np.flatnonzero(np.abs(uniform - time) > tolerance / rate)
    if bad.size:
        worst = int(bad[0])
        raise InputError(
            f"{source}: the time column is not uniform at the stated rate {rate:g} Hz: frame "
            f"{worst + 1} reads t = {time[worst]:.6g} s but {uniform[worst]:.6g} s is expected. "
            "Check the file's rate or for dropped frames."
        )
    return uniform


@dataclass(frozen=True, eq=False)
class Markers:
    """Marker trajectories in the lab frame.

    Attributes:
        time: (n,) s, uniform.
        names: marker names, length m.
        xyz: (n, m, 3) m, lab frame; NaN where a marker is missing.
        rate: Hz, frame rate.
        source: file (or description) the markers come from.
    """

    time: np.ndarray
    names: tuple[str, ...]
    xyz: np.ndarray
    rate: float
    source: str = ""

    def __post_init__(self):
        object.__setattr__(self, "time", _as_float(self.time, "time"))
        object.__setattr__(self, "xyz", _as_float(self.xyz, "xyz"))
        object.__setattr__(self, "names", tuple(str(n) for n in self.names))
        n, m = self.time.shape[0], len(self.names)
        if self.xyz.shape != (n, m, 3):
            raise ValueError(f"Markers.xyz has shape {self.xyz.shape}, expected {(n, m, 3)}.")
        if len(set(self.names)) != m:
            raise InputError(f"{self.source}: duplicate marker names in {self.names}.")

    @property
    def n_frames(self) -> int:
        """Number of frames n."""
        return self.time.shape[0]

    def index(self, name: str) -> int:
        """Column index of a marker; raises InputError listing the available names.

        Vicon prefixes labels with the subject (``Subject:RASI``); such a label is found by
        its bare name when only one subject has it.
        """
        try:
            return self.names.index(name)
        except ValueError:
            prefixed = [i for i, n in enumerate(self.names) if n.rpartition(":")[2] == name]
            if len(prefixed) == 1:
                return prefixed[0]
            raise InputError(
                f"{self.source or 'markers'}: no marker named {name!r}. "
                f"Available markers: {', '.join(self.names)}."
            ) from None

    def get(self, name: str) -> np.ndarray:
        """Trajectory of one marker, (n, 3) m, lab frame."""
        return self.xyz[:, self.index(name), :]

    def select(self, names: Sequence[str]) -> Markers:
        """Markers restricted to ``names`` (in that order)."""
        columns = [self.index(n) for n in names]
        return dataclasses.replace(self, names=tuple(names), xyz=self.xyz[:, columns, :])

    def window(self, start: float, stop: float) -> Markers:
        """Frames with ``start <= time <= stop`` (s)."""
        keep = (self.time >= start - 1e-9) & (self.time <= stop + 1e-9)
        return dataclasses.replace(self, time=self.time[keep], xyz=self.xyz[keep])

    def with_xyz(self, xyz: np.ndarray) -> Markers:
        """Same markers with new coordinates, (n, m, 3) m."""
        return dataclasses.replace(self, xyz=xyz)


@dataclass(frozen=True, eq=False)
class ForcePlate:
    """One force plate (or one foot's ground reaction) in the lab frame.

    Attributes:
        time: (k,) s.
        force: (k, 3) N, ground reaction force ON THE FOOT, lab frame (Z > 0 in stance).
        cop: (k, 3) m, centre of pressure, lab frame.
        free_moment: (k, 3) N m, free moment on the foot about the COP (mostly vertical).
        name: plate or foot name (e.g. "1", "right").
        corners: (4, 3) m, plate corners in the lab frame, or None when unknown.
    """

    time: np.ndarray
    force: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    name: str
    corners: np.ndarray | None = None

    def __post_init__(self):
        for field in ("time", "force", "cop", "free_moment"):
            object.__setattr__(self, field, _as_float(getattr(self, field), field))
        if self.corners is not None:
            object.__setattr__(self, "corners", _as_float(self.corners, "corners"))
        k = self.time.shape[0]
        for field in ("force", "cop", "free_moment"):
            if getattr(self, field).shape != (k, 3):
                raise ValueError(f"ForcePlate.{field} has shape {getattr(self, field).shape}.")

    @property
    def rate(self) -> float:
        """Hz, from the mean sample period."""
        return float((self.time.size - 1) / (self.time[-1] - self.time[0]))

    def window(self, start: float, stop: float) -> ForcePlate:
        """Samples with ``start <= time <= stop`` (s)."""
        keep = (self.time >= start - 1e-9) & (self.time <= stop + 1e-9)
        return dataclasses.replace(
            self, time=self.time[keep], force=self.force[keep], cop=self.cop[keep],
            free_moment=self.free_moment[keep],
        )


@dataclass(frozen=True, eq=False)
class Trial:
    """Markers and force plates of one trial, lab frame, SI units.

    Attributes:
        markers: marker trajectories.
        plates: force plates (or per-foot ground reactions).
        source: file(s) the trial comes from.
    """

    markers: Markers
    plates: tuple[ForcePlate, ...] = ()
    source: str = ""

    def __post_init__(self):
        object.__setattr__(self, "plates", tuple(self.plates))

    def plate(self, name: str) -> ForcePlate:
        """The plate called ``name``; raises InputError listing the plate names."""
        for plate in self.plates:
            if plate.name == name:
                return plate
        raise InputError(
            f"{self.source or 'trial'}: no force plate named {name!r}. "
            f"Available plates: {', '.join(p.name for p in self.plates) or 'none'}."
        )

    def shifted(self, t0: float) -> Trial:
        """Same trial with time zero moved to ``t0`` (s): every time becomes ``t - t0``."""
        markers = dataclasses.replace(self.markers, time=self.markers.time - t0)
        plates = tuple(dataclasses.replace(p, time=p.time - t0) for p in self.plates)
        return dataclasses.replace(self, markers=markers, plates=plates)
