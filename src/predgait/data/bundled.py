"""Real trials shipped inside the package (the ``predgait/datasets`` folder).

* ``subject01_walk1``: OpenSim Gait2354 example walk (TRC 60 Hz, 41 markers; GRF MOT
  600 Hz, right foot prefix "", left foot prefix "1_"); treadmill-like, Y-up in the file.
* ``winter_a1``: Winter (2009) Appendix A Table A.1, 2D sagittal markers in cm, 69.9 Hz.

Each folder has a README.md with source, license and the facts the tests rely on.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

from predgait.data.storage import read_external_loads, read_grf_mot
from predgait.data.trc import read_trc
from predgait.data.trial import Markers, Trial, uniform_time
from predgait.errors import InputError

_SUBJECTS = {
    "subject01_walk1": {"mass": 72.6, "height": 1.8034, "source": "OpenSim Gait2354 example"},
    "winter_a1": {"mass": 56.7, "height": None, "source": "Winter 2009, Appendix A"},
}

#: Frame rate of Winter's Table A.1 (Hz).
WINTER_RATE = 69.9


def bundled_path(name: str) -> Path:
    """Path of a shipped dataset folder or file.

    Args:
        name: ``"subject01_walk1"``, ``"winter_a1"`` or a file in one, e.g.
            ``"subject01_walk1/subject01_walk1.trc"``.
    """
    # The package's folder on disk (importlib.resources would import zipfile and its
    # readers on every run for the same path: predgait is installed as files).
    root = Path(__file__).resolve().parents[1] / "datasets"
    target = root.joinpath(*name.split("/"))
    if not target.is_file() and not target.is_dir():
        available = sorted(p.name for p in root.iterdir() if p.is_dir() and p.name[0] != "_")
        raise InputError(f"no bundled dataset entry {name!r}; datasets: {', '.join(available)}.")
    return target


def subject_info(name: str) -> dict:
    """Subject data of a bundled trial: mass (kg), height (m, None if unknown), source."""
    if name not in _SUBJECTS:
        raise InputError(f"no subject info for {name!r}; known: {', '.join(_SUBJECTS)}.")
    return dict(_SUBJECTS[name])


def load_subject01() -> Trial:
    """The subject01 walk in the lab frame: markers (60 Hz, m) and plates "right", "left".

    Plates are the raw 600 Hz ground reactions on each foot (not thresholded: they keep
    about 2 N of noise and an extrapolated COP in swing; see
    :func:`predgait.data.resample.resample_plate`).
    """
    folder = bundled_path("subject01_walk1")
    markers = read_trc(folder / "subject01_walk1.trc", axes="opensim", forward="+x")
    names = read_external_loads(folder / "subject01_walk1_grf.xml")
    plates = read_grf_mot(folder / "subject01_walk1_grf.mot", names=names, axes="opensim")
    return Trial(markers=markers, plates=plates, source=str(folder))


def read_winter_table(path) -> Markers:
    """Read Winter's Table A.1 text file (2D, cm) into lab-frame markers.

    File X (forward) -> lab X, file Y (up) -> lab Z, lab Y (lateral) = 0.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found.")
    lines = [ln for ln in path.read_text().splitlines() if ln.strip()]
    labels = shlex.split(lines[0])
    names = labels[2:]
    data = np.array([[float(v) for v in ln.split()] for ln in lines[2:]])
    if data.shape[1] != 2 + 2 * len(names):
        raise InputError(f"{path}: {data.shape[1]} columns for {len(names)} 2D markers.")
    time = uniform_time(data[:, 1], WINTER_RATE, source=str(path))
    planar = data[:, 2:].reshape(len(time), len(names), 2) * 1e-2
    xyz = np.zeros((len(time), len(names), 3))
    xyz[:, :, 0], xyz[:, :, 2] = planar[:, :, 0], planar[:, :, 1]
    return Markers(time=time, names=tuple(names), xyz=xyz, rate=WINTER_RATE, source=str(path))


def load_winter_a1() -> Markers:
    """Winter's Table A.1 markers (106 frames, 69.9 Hz, 8 markers), lab frame, m."""
    return read_winter_table(bundled_path("winter_a1/WinterTableA1.txt"))
