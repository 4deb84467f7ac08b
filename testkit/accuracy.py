"""Accuracy of lifted motion against known 3-D truth (used by ``benchmarks/bench_pose.py`` and tests).

All positions are global joint positions ``(T, J, 3)`` in metres, Y up, on the canonical skeleton.
"""

from __future__ import annotations

import numpy as np

from lifting.fit import FOOT_CLEARANCE
from motioncore.skeleton import CANONICAL


def similarity_align(pred: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """Per-frame Procrustes with scale: ``pred (T, J, 3)`` moved onto ``gt (T, J, 3)``."""
    mp, mg = pred.mean(-2, keepdims=True), gt.mean(-2, keepdims=True)
    a, b = pred - mp, gt - mg
    u, s, vt = np.linalg.svd(np.einsum("tji,tjk->tik", a, b))
    v, ut = vt.transpose(0, 2, 1), u.transpose(0, 2, 1)
    d = np.sign(np.linalg.det(v @ ut))
    s = s.copy()
    s[:, 2] *= d
    v[:, :, 2] *= d[:, None]
    r = v @ ut
    scale = s.sum(-1) / (a**2).sum((-1, -2))
    return scale[:, None, None] * np.einsum("tij,tkj->tki", r, a) + mg


def yaw_align(pred: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """The rotation ``(3, 3)`` about +Y that best maps ``pred (..., 3)`` onto ``gt (..., 3)``."""
    a, b = pred.reshape(-1, 3), gt.reshape(-1, 3)
    th = np.arctan2((a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]).sum(), (a[:, 0] * b[:, 0] + a[:, 2] * b[:, 2]).sum())
    c, s = np.cos(th), np.sin(th)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def acceleration(x: np.ndarray, fps: float) -> float:
    """Mean joint acceleration magnitude (m/s^2) of ``x (T, J, 3)``."""
    if len(x) < 3:
        return float("nan")
    return float(np.linalg.norm(x[2:] - 2 * x[1:-1] + x[:-2], axis=-1).mean() * fps**2)


def compare(pred: np.ndarray, gt: np.ndarray, fps: float) -> dict:
    """Metrics of predicted against true global joint positions, both ``(T, J, 3)`` metres."""
    pr, gr = pred - pred[:, :1], gt - gt[:, :1]
    rot = yaw_align(pr, gr)
    root_p = pred[:, 0] @ rot.T
    offset = (gt[:, 0] - root_p).mean(0)
    feet = list(CANONICAL.feet)
    return {
        "mpjpe_mm": 1000 * float(np.linalg.norm(pr @ rot.T - gr, axis=-1).mean()),
        "pa_mpjpe_mm": 1000 * float(np.linalg.norm(similarity_align(pred, gt) - gt, axis=-1).mean()),
        "jitter": acceleration(pred, fps),
        "root_mm": 1000 * float(np.linalg.norm((root_p + offset - gt[:, 0])[:, [0, 2]], axis=-1).mean()),
        "min_foot_m": float((pred[:, feet, 1] - FOOT_CLEARANCE).min()),
    }
