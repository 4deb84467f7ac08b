"""Time-series helpers for landmark tracks: zero-phase low-pass, gap interpolation, segments."""

from __future__ import annotations

import numpy as np

DEFAULT_CUTOFF_HZ = 3.0  # Hu et al. 2024, §4.6.1
DEFAULT_ORDER = 4
CUTOFF_RANGE = (0.1, 30.0)  # Hz: a cutoff a pose track can use (30 Hz: the Nyquist frequency at 60 fps); 0 = off


def check_cutoff(cutoff_hz: float) -> None:
    """ValueError unless ``cutoff_hz`` is 0 (no filter) or in :data:`CUTOFF_RANGE` (``pose --cutoff``)."""
    if cutoff_hz != 0 and not CUTOFF_RANGE[0] <= cutoff_hz <= CUTOFF_RANGE[1]:  # nan too
        raise ValueError(f"expected 0 (no filter) or a cutoff from {CUTOFF_RANGE[0]:g} to {CUTOFF_RANGE[1]:g} Hz, "
                         f"got {cutoff_hz}")


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float | None = DEFAULT_CUTOFF_HZ, order: int = DEFAULT_ORDER,
            axis: int = 0) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` along ``axis`` (time), sampled at ``fps``.

    Butterworth + ``filtfilt`` as scipy.signal has them (forward and backward, so no lag; the effective
    order is ``2 * order``), with odd-extension padding shortened for short clips. ``cutoff_hz``
    None, 0 or at/above the Nyquist frequency returns a copy unfiltered. ``x`` must be finite.
    """
    x = np.asarray(x, dtype=np.float64)
    if not fps > 0:
        raise ValueError(f"lowpass: expected fps > 0, got {fps}")
    if cutoff_hz is not None and cutoff_hz < 0:
        raise ValueError(f"lowpass: expected cutoff_hz >= 0, got {cutoff_hz}")
    n = x.shape[axis] if x.ndim else 0
    if not cutoff_hz or cutoff_hz >= 0.5 * fps or n < 2:
        return x.copy()
    if not np.isfinite(x).all():
        raise ValueError("lowpass: expected finite values; interpolate gaps first")
    b, a = butterworth(order, cutoff_hz / (0.5 * fps))
    padlen = min(3 * max(len(a), len(b)), n - 1)
    y = _filtfilt(b, a, np.moveaxis(x, axis, 0).reshape(n, -1), padlen)
    return np.ascontiguousarray(np.moveaxis(y.reshape(np.moveaxis(x, axis, 0).shape), 0, axis))


def butterworth(order: int, wn: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital low-pass Butterworth ``(b, a)``, ``wn`` the cutoff as a fraction of Nyquist: the analog
    prototype's poles, pre-warped, through the bilinear transform (what ``scipy.signal.butter`` does;
    written out here because importing scipy.signal costs most of a second at every start)."""
    if not 0 < wn < 1:
        raise ValueError(f"butterworth: expected 0 < wn < 1, got {wn}")
    k = np.arange(-order + 1, order, 2)
    poles = -np.exp(1j * np.pi * k / (2 * order))  # unit-cutoff analog prototype, left half-plane
    warped = 4.0 * np.tan(np.pi * wn / 2.0)  # fs = 2 as scipy
    p = warped * poles
    z_poles = (4.0 + p) / (4.0 - p)
    gain = np.real(warped**order / np.prod(4.0 - p))
    b = gain * np.real(np.poly(-np.ones(order)))
    a = np.real(np.poly(z_poles))
    return b, a


def _lfilter(b: np.ndarray, a: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """Direct form II transposed along axis 0 of ``x (T, C)``, initial state ``zi (order, C)``."""
    y = np.empty_like(x)
    z = zi.copy()
    for t in range(x.shape[0]):
        y[t] = b[0] * x[t] + z[0]
        z[:-1] = z[1:] + b[1:-1, None] * x[t] - a[1:-1, None] * y[t]
        z[-1] = b[-1] * x[t] - a[-1] * y[t]
    return y


def _lfilter_zi(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The steady-state initial conditions for a unit step (as ``scipy.signal.lfilter_zi``)."""
    n = len(a)
    companion = np.zeros((n - 1, n - 1))
    companion[0] = -a[1:]
    companion[1:, :-1] = np.eye(n - 2)
    i_minus_a = np.eye(n - 1) - companion.T
    return np.linalg.solve(i_minus_a, b[1:] - a[1:] * b[0])


def _filtfilt(b: np.ndarray, a: np.ndarray, x: np.ndarray, padlen: int) -> np.ndarray:
    """Zero-phase filtering of ``x (T, C)`` along time with odd extension by ``padlen`` samples."""
    if padlen > 0:
        x = np.concatenate([2 * x[:1] - x[padlen:0:-1], x, 2 * x[-1:] - x[-2:-padlen - 2:-1]])
    zi = _lfilter_zi(b, a)[:, None]
    y = _lfilter(b, a, x, zi * x[:1])
    y = _lfilter(b, a, y[::-1], zi * y[-1:])[::-1]
    return y[padlen:len(y) - padlen] if padlen > 0 else y


def _centred_windows(x: np.ndarray, size: int) -> np.ndarray:
    """Centred windows ``(T, size)`` over ``x (T,)``, edges repeated (scipy.ndimage's mode "nearest")."""
    half = size // 2
    return np.lib.stride_tricks.sliding_window_view(np.pad(x, (half, size - 1 - half), mode="edge"), size)


def percentile_1d(x: np.ndarray, percentile: float, size: int) -> np.ndarray:
    """Sliding percentile of ``x (T,)`` over ``size`` frames, as ``scipy.ndimage.percentile_filter``."""
    rank = min(size - 1, int(size * percentile / 100.0))
    return np.partition(_centred_windows(x, size), rank, axis=1)[:, rank].copy()


def maximum_1d(x: np.ndarray, size: int) -> np.ndarray:
    """Sliding maximum, as ``scipy.ndimage.maximum_filter1d(mode="nearest")``."""
    return _centred_windows(x, size).max(axis=1)


def mean_1d(x: np.ndarray, size: int) -> np.ndarray:
    """Sliding mean, as ``scipy.ndimage.uniform_filter1d(mode="nearest")``."""
    return _centred_windows(x, size).mean(axis=1)


def interpolate_gaps(x: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Fill the frames where ``valid (T,)`` is False by linear interpolation along axis 0.

    Frames before the first and after the last valid one take the nearest valid value.
    Raises ValueError when no frame is valid.
    """
    x = np.array(x, dtype=np.float64, copy=True)
    valid = np.asarray(valid, dtype=bool)
    if x.shape[0] != valid.shape[0]:
        raise ValueError(f"interpolate_gaps: expected {x.shape[0]} flags, got {valid.shape[0]}")
    if not valid.any():
        raise ValueError("interpolate_gaps: no valid frame")
    if valid.all():
        return x
    t = np.arange(len(valid))
    flat = x.reshape(len(valid), -1)
    for k in range(flat.shape[1]):
        flat[~valid, k] = np.interp(t[~valid], t[valid], flat[valid, k])
    return flat.reshape(x.shape)


def runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` runs of True in ``flags (T,)``."""
    f = np.concatenate([[False], np.asarray(flags, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(f.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def longest_segment(found: np.ndarray, max_gap: int) -> tuple[int, int]:
    """The longest ``[start, stop)`` span that starts and ends with a found frame and whose gaps
    (runs of not-found frames) are at most ``max_gap`` frames; ``(0, 0)`` when nothing is found."""
    pieces = runs(found)
    if not pieces:
        return 0, 0
    best, cur = (0, 0), list(pieces[0])
    for a, b in pieces[1:]:
        if a - cur[1] <= max_gap:
            cur[1] = b
        else:
            best = max(best, tuple(cur), key=lambda s: s[1] - s[0])
            cur = [a, b]
    return max(best, tuple(cur), key=lambda s: s[1] - s[0])
