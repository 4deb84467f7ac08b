"""The pinhole camera of the lift: focal length from an assumed field of view, and the per-frame
root translation that projects the fitted skeleton onto the image landmarks.

The camera is OpenCV-like (x right, y down, z forward); :func:`solve_translation` takes and returns
points in the Y-up frame of BlazePose's world landmarks (x right, y up, z toward the camera).
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_FOV_DEG = 60.0  # assumed field of view across the longer image side
FOV_RANGE = (1.0, 179.0)  # degrees, both ends excluded


def check_fov(fov_deg: float) -> None:
    """ValueError unless ``fov_deg`` is a field of view in :data:`FOV_RANGE` (``pose --fov`` is checked with it)."""
    if not FOV_RANGE[0] < fov_deg < FOV_RANGE[1]:  # nan too
        raise ValueError(f"expected a field of view in ({FOV_RANGE[0]:g}, {FOV_RANGE[1]:g}) degrees, got {fov_deg}")


def focal_length(width: int, height: int, fov_deg: float = DEFAULT_FOV_DEG) -> float:
    """Focal length in pixels for a field of view ``fov_deg`` across the longer image side."""
    check_fov(fov_deg)
    return 0.5 * max(width, height) / math.tan(math.radians(fov_deg) / 2)


def solve_translation(
    points: np.ndarray,
    pixels: np.ndarray,
    weights: np.ndarray,
    focal: float,
    centre: tuple[float, float],
) -> np.ndarray:
    """Per-frame translation ``(T, 3)`` (Y-up frame: x right, y up, z toward the camera) that makes
    ``points + t`` project onto ``pixels``: hip-centred ``points (T, K, 3)`` in the Y-up camera-
    aligned frame, ``pixels (T, K, 2)``, ``weights (T, K)`` >= 0, a pinhole of focal length
    ``focal`` px and principal point ``centre``. Linear least squares on the projection equations
    ``f (X + tx) = (u - cx)(Z + tz)`` (and the same for y), in camera coordinates."""
    p = np.asarray(points, np.float64) * np.array([1.0, -1.0, -1.0])  # -> camera: y down, z forward
    du = pixels[..., 0] - centre[0]
    dv = pixels[..., 1] - centre[1]
    w = np.sqrt(np.clip(weights, 0.0, None))
    t_count, k = du.shape
    a = np.zeros((t_count, 2 * k, 3))
    b = np.zeros((t_count, 2 * k))
    a[:, :k, 0] = focal
    a[:, :k, 2] = -du
    b[:, :k] = du * p[..., 2] - focal * p[..., 0]
    a[:, k:, 1] = focal
    a[:, k:, 2] = -dv
    b[:, k:] = dv * p[..., 2] - focal * p[..., 1]
    ww = np.concatenate([w, w], axis=1)
    a, b = a * ww[..., None], b * ww
    ata = np.einsum("tki,tkj->tij", a, a) + 1e-9 * np.eye(3)
    atb = np.einsum("tki,tk->ti", a, b)
    t = np.linalg.solve(ata, atb[..., None])[..., 0]
    return t * np.array([1.0, -1.0, -1.0])
