"""One BLAS thread while small dense linear algebra runs (Riccati steps, Ipopt's MUMPS).

OpenBLAS (NumPy's, SciPy's and CasADi's each bundle one) runs a matrix product of a
~100 x 100 matrix on all cores, and its worker threads busy-wait for the next one. On
a 2-core machine shared with other processes that costs far more than it saves:
measured on such a machine, SciPy's ``expm`` of a 99 x 99 matrix took 175 ms of CPU
with the default threads and 1 ms with one, and the linear-system part of the
whole-body stance solve 28 s wall with the default threads and 7 s with one.
:func:`one_blas_thread` sets every OpenBLAS loaded in the process to one thread and
restores the previous counts on exit. Where the libraries cannot be found (no
``/proc/self/maps``: not Linux), it changes nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Iterator
from pathlib import Path

#: (get, set) symbol pairs: OpenBLAS' own (CasADi's copy), SciPy's and NumPy's builds.
_SYMBOLS = (("openblas_get_num_threads", "openblas_set_num_threads"),
            ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
            ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"))


def _controls() -> list[tuple]:
    """(get, set) functions of every OpenBLAS loaded in this process."""
    import scipy.linalg  # noqa: F401  (loads SciPy's OpenBLAS, which expm and solve use)

    maps = Path("/proc/self/maps")
    if not maps.is_file():
        return []
    paths = {line.split()[-1] for line in maps.read_text().splitlines()
             if "openblas" in line.rsplit("/", 1)[-1]}
    found = []
    for path in sorted(paths):
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for get, set_ in _SYMBOLS:
            if hasattr(library, get) and hasattr(library, set_):
                found.append((getattr(library, get), getattr(library, set_)))
                break
    return found


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with every loaded OpenBLAS on one thread (module docstring)."""
    controls = _controls()
    before = [get() for get, _ in controls]
    for _, set_ in controls:
        set_(1)
    try:
        yield
    finally:
        for (_, set_), count in zip(controls, before, strict=True):
            set_(count)
