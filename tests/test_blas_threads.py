"""one_blas_thread: every OpenBLAS in the process on one thread inside, as before after."""

import sys

import numpy as np
import pytest

from predgait.blas_threads import _controls, one_blas_thread


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps")
def test_one_thread_inside_restored_after():
    controls = _controls()
    assert len(controls) >= 2                    # NumPy's and SciPy's at least
    before = [get() for get, _ in controls]
    with one_blas_thread():
        assert [get() for get, _ in controls] == [1] * len(controls)
        product = np.ones((200, 200)) @ np.ones((200, 200))
    assert [get() for get, _ in controls] == before
    assert product[0, 0] == 200.0
