"""Digital Butterworth low-pass design and zero-phase filtering in numpy.

The same algorithms as SciPy's ``signal.butter`` (analog prototype, pre-warped bilinear
transform) and ``signal.filtfilt`` (odd extension, steady-state initial conditions,
forward and backward passes), checked equal to them in the tests. They live here because
importing ``scipy.signal`` costs more than a second of CPU (it imports ``scipy.stats``),
which every command that filters markers would pay.

The recursion runs on blocks of samples: within a block the output is the state response
plus the impulse-response (Toeplitz) matrix times the input, so the Python loop is over
blocks, not samples.

Reference: Oppenheim AV, Schafer RW (2010) Discrete-Time Signal Processing, 3rd ed.,
sec. 7.2 (bilinear transform) and 6.5 (transposed direct form II).
"""

from __future__ import annotations

import functools

import numpy as np

#: Samples per block of the block recursion.
BLOCK = 64


def butter_lowpass(order: int, cutoff: float, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """Numerator ``b`` and denominator ``a`` of a digital Butterworth low-pass.

    Args:
        order: filter order (>= 1).
        cutoff: Hz, -3 dB frequency, 0 < cutoff < rate / 2.
        rate: Hz, sample rate.
    """
    m = np.arange(-order + 1, order, 2)
    poles = -np.exp(1j * np.pi * m / (2 * order))          # analog prototype, unit cut-off
    warped = 4.0 * np.tan(np.pi * cutoff / rate)            # pre-warped, sample rate 2
    poles = warped * poles
    gain = warped ** order
    digital = (4.0 + poles) / (4.0 - poles)                 # bilinear transform, 2 fs = 4
    gain = gain * np.real(1.0 / np.prod(4.0 - poles))
    b = gain * np.real(np.poly(-np.ones(order)))           # all zeros at z = -1
    a = np.real(np.poly(digital))
    return b, a


def _state_space(b: np.ndarray, a: np.ndarray):
    """(A, B, C, D) of the transposed direct form II: z' = A z + B x, y = C z + D x."""
    n = len(a) - 1
    A = np.zeros((n, n))
    A[:, 0] = -a[1:]
    A[np.arange(n - 1), np.arange(1, n)] = 1.0
    B = b[1:] - a[1:] * b[0]
    C = np.zeros(n)
    C[0] = 1.0
    return A, B, C, b[0]


def steady_state(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Initial state for a unit step input (as SciPy's ``lfilter_zi``)."""
    A, B, _, _ = _state_space(b, a)
    return np.linalg.solve(np.eye(len(B)) - A, B)


@functools.lru_cache(maxsize=16)
def _block_matrices(b: bytes, a: bytes, size: int) -> tuple[np.ndarray, ...]:
    """The block recursion's matrices of the filter ``b``, ``a`` (float64 bytes).

    (A^j for j = 0..size, C A^j, the impulse-response Toeplitz matrix, A^(size-1-j) B)
    for blocks of ``size`` samples. Kept per filter and block size: a trial filters many
    signals with the same filter.
    """
    A, B, _, D = _state_space(np.frombuffer(b), np.frombuffer(a))
    # Powers A^j (j = 0..size); C = e_0, so C A^j is row 0 of A^j.
    powers = np.empty((size + 1, len(B), len(B)))
    powers[0] = np.eye(len(B))
    for j in range(size):
        powers[j + 1] = A @ powers[j]
    observe = powers[:size, 0, :]                                          # (size, order)
    h = np.concatenate([[D], observe[:size - 1] @ B])                      # impulse response
    lag = np.subtract.outer(np.arange(size), np.arange(size))
    toeplitz = np.where(lag >= 0, h[np.maximum(lag, 0)], 0.0)
    drive = (powers[size - 1::-1] @ B).T                                   # A^(size-1-j) B
    for array in (powers, observe, toeplitz, drive):
        array.setflags(write=False)
    return powers, observe, toeplitz, drive


def lfilter(b: np.ndarray, a: np.ndarray, x: np.ndarray, state: np.ndarray
            ) -> np.ndarray:
    """Filter along axis 0 from the initial ``state`` (order, ...) ; returns y like x."""
    b, a = np.asarray(b, dtype=float), np.asarray(a, dtype=float)
    size = min(BLOCK, len(x))
    powers, observe, toeplitz, drive = _block_matrices(b.tobytes(), a.tobytes(), size)
    z = np.asarray(state, dtype=float).reshape(len(a) - 1, -1)
    flat = np.reshape(x, (len(x), -1))
    out = np.empty(flat.shape)
    for start in range(0, len(x), size):
        block = flat[start:start + size]
        k = len(block)
        out[start:start + k] = observe[:k] @ z + toeplitz[:k, :k] @ block
        z = powers[k] @ z + drive[:, size - k:] @ block   # A^k z + sum_j A^(k-1-j) B x_j
    return out.reshape(np.shape(x))


def filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray, *, axis: int = 0, padlen: int
             ) -> np.ndarray:
    """Zero-phase filtering: odd extension by ``padlen``, forward and backward passes.

    Requires ``x.shape[axis] > padlen``.
    """
    x = np.moveaxis(np.asarray(x, dtype=float), axis, 0)
    ext = np.concatenate([2 * x[:1] - x[padlen:0:-1], x,
                          2 * x[-1:] - x[-2:-padlen - 2:-1]])
    zi = steady_state(b, a)
    shape = (len(zi),) + (1,) * (x.ndim - 1)
    forward = lfilter(b, a, ext, zi.reshape(shape) * ext[:1])
    backward = lfilter(b, a, forward[::-1], zi.reshape(shape) * forward[-1:])[::-1]
    return np.moveaxis(backward[padlen:len(backward) - padlen], 0, axis)
