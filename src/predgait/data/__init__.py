"""predgait.data: trial files to clean lab-frame arrays (SI units).

Lab frame: X forward, Y left, Z up. Readers map each file's axes and units once.

The names below are loaded on first use (PEP 562), so that importing one reader does not
import SciPy's signal, interpolate and stats packages for every command.
"""

from __future__ import annotations

import importlib

#: Public name -> submodule of predgait.data that defines it.
_SOURCES = {
    "bundled": ("bundled_path", "load_subject01", "load_winter_a1", "subject_info"),
    "c3d": ("read_c3d",),
    "csvfile": ("read_markers_csv",),
    "derivatives": ("Method", "differentiate"),
    "events": ("Events", "Side", "detect_events", "events_from_kinematics",
               "events_from_plate"),
    "filters": ("lowpass", "moving_average", "residual_analysis", "winter_correction"),
    "frames": ("FileAxes", "Forward", "lab_rotation"),
    "gaps": ("Edges", "fill_gaps", "find_gaps"),
    "resample": ("filter_plate", "resample_plate", "threshold_plate"),
    "storage": ("read_external_loads", "read_grf_mot", "read_storage", "write_csv",
                "write_storage"),
    "trc": ("read_trc",),
    "trial": ("ForcePlate", "Markers", "Trial", "uniform_time"),
}
_MODULE_OF = {name: module for module, names in _SOURCES.items() for name in names}

__all__ = sorted(_MODULE_OF)


def __getattr__(name: str):
    """Import the submodule that defines ``name`` on first access."""
    if name not in _MODULE_OF:
        raise AttributeError(f"module 'predgait.data' has no attribute '{name}'")
    value = getattr(importlib.import_module(f"predgait.data.{_MODULE_OF[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
