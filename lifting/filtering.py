"""Time-series helpers for landmark tracks: zero-phase low-pass, gap interpolation, segments."""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, filtfilt

DEFAULT_CUTOFF_HZ = 3.0  # Hu et al. 2024, §4.6.1
DEFAULT_ORDER = 4


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float | None = DEFAULT_CUTOFF_HZ, order: int = DEFAULT_ORDER,
            axis: int = 0) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` along ``axis`` (time), sampled at ``fps``.

    ``scipy.signal.butter`` + ``filtfilt`` (forward and backward, so no lag; the effective
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
    b, a = butter(order, cutoff_hz / (0.5 * fps), btype="low")
    padlen = min(3 * max(len(a), len(b)), n - 1)
    return np.ascontiguousarray(filtfilt(b, a, x, axis=axis, padlen=padlen))


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
