"""Import ADAM (symbolic rigid-body dynamics) without SciPy's spatial package.

``adam.model`` imports its MuJoCo model factory on every import, and that factory imports
``scipy.spatial.transform.Rotation`` at module level, which loads all of ``scipy.spatial``
(Qhull, k-d trees, ``scipy.sparse``, ``scipy.linalg``: about 0.8 s of the 1.1 s that
``import adam.casadi`` takes). Predgait builds its ADAM models from URDFs and never uses
the MuJoCo factory, so :func:`kindyn_class` imports ADAM with a placeholder
``scipy.spatial.transform`` whose ``Rotation`` imports the real class on first use (the
MuJoCo factory still works if some caller uses it). The placeholder is removed from
``sys.modules`` as soon as ADAM is imported; if SciPy's module is already loaded it is used.
"""

from __future__ import annotations

import importlib
import sys
import types

_TRANSFORM = "scipy.spatial.transform"


class _DeferredRotation:
    """Stands for ``scipy.spatial.transform.Rotation``; imports it on first attribute use."""

    def __getattr__(self, name: str):
        from scipy.spatial.transform import Rotation

        return getattr(Rotation, name)


def _import_adam_model() -> None:
    """Import ``adam.model`` (and ``adam.core``) with the deferred Rotation, once."""
    if "adam.model" in sys.modules or _TRANSFORM in sys.modules:
        return
    placeholder = types.ModuleType(_TRANSFORM)
    placeholder.Rotation = _DeferredRotation()
    sys.modules[_TRANSFORM] = placeholder
    try:
        importlib.import_module("adam.core")
    finally:
        if sys.modules.get(_TRANSFORM) is placeholder:
            del sys.modules[_TRANSFORM]


def kindyn_class(backend: str = "casadi") -> type:
    """ADAM's ``KinDynComputations`` of ``backend`` (``"casadi"`` or ``"numpy"``)."""
    if backend not in ("casadi", "numpy"):
        raise ValueError(f"unknown ADAM backend {backend!r}")
    _import_adam_model()
    return importlib.import_module(f"adam.{backend}").KinDynComputations


def representations():
    """ADAM's ``Representations`` enum (frame velocity representations)."""
    _import_adam_model()
    return importlib.import_module("adam.core.constants").Representations
