"""predgait.data: trial files to clean lab-frame arrays (SI units).

Lab frame: X forward, Y left, Z up. Readers map each file's axes and units once.
"""

from predgait.data.bundled import bundled_path, load_subject01, load_winter_a1, subject_info
from predgait.data.c3d import read_c3d
from predgait.data.csvfile import read_markers_csv
from predgait.data.derivatives import Method, differentiate
from predgait.data.events import (
    Events,
    Side,
    detect_events,
    events_from_kinematics,
    events_from_plate,
)
from predgait.data.filters import lowpass, moving_average, residual_analysis, winter_correction
from predgait.data.frames import FileAxes, Forward, lab_rotation
from predgait.data.gaps import Edges, fill_gaps, find_gaps
from predgait.data.resample import filter_plate, resample_plate, threshold_plate
from predgait.data.storage import (
    read_external_loads,
    read_grf_mot,
    read_storage,
    write_csv,
    write_storage,
)
from predgait.data.trc import read_trc
from predgait.data.trial import ForcePlate, Markers, Trial, uniform_time

__all__ = [
    "Edges", "Events", "FileAxes", "ForcePlate", "Forward", "Markers", "Method", "Side",
    "Trial", "bundled_path", "detect_events", "differentiate", "events_from_kinematics",
    "events_from_plate", "fill_gaps", "filter_plate", "find_gaps", "lab_rotation",
    "load_subject01", "load_winter_a1", "lowpass", "moving_average", "read_c3d",
    "read_external_loads", "read_grf_mot", "read_markers_csv", "read_storage", "read_trc",
    "resample_plate", "residual_analysis", "subject_info", "threshold_plate", "uniform_time",
    "winter_correction", "write_csv", "write_storage",
]
