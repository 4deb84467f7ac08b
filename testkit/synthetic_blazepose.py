"""Crude synthetic humanoid frames and clips (OpenCV drawing) for tests and benchmarks.

A stick figure with thick limbs, a round head with two eyes, drawn on a
plain background; BlazePose detects and tracks such renders.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from motioncore.mp4 import write_mp4

_SKIN = (150, 180, 220)  # BGR
_SHIRT = (60, 60, 200)
_TROUSERS = (120, 70, 40)


def humanoid_joints(cx: float, top: float, height: float, phase: float = 0.0) -> dict[str, np.ndarray]:
    """2-D joint positions (pixels) of a walking figure ``height`` px tall.

    ``phase`` (radians) swings arms and legs in opposite directions.
    """
    u = height / 8.0  # one head height
    swing = math.sin(phase)

    def p(x, y):
        return np.array([cx + x * u, top + y * u])

    j = {"head": p(0, 0.55), "neck": p(0, 1.2), "pelvis": p(0, 4.0)}
    j["l_shoulder"], j["r_shoulder"] = p(0.95, 1.45), p(-0.95, 1.45)
    j["l_hip"], j["r_hip"] = p(0.55, 4.0), p(-0.55, 4.0)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        arm = -sign * swing * 0.8
        leg = sign * swing * 0.45
        sh, hip = j[f"{side}_shoulder"], j[f"{side}_hip"]
        j[f"{side}_elbow"] = sh + np.array([sign * 0.25 + arm * 0.6, 1.4]) * u
        j[f"{side}_wrist"] = j[f"{side}_elbow"] + np.array([arm * 0.9, 1.3]) * u
        j[f"{side}_knee"] = hip + np.array([leg * 0.9, 1.9]) * u
        j[f"{side}_ankle"] = j[f"{side}_knee"] + np.array([leg * 0.5, 1.9]) * u
        j[f"{side}_toe"] = j[f"{side}_ankle"] + np.array([-0.5, 0.15]) * u
    return j


def draw_humanoid(image: np.ndarray, cx: float, top: float, height: float, phase: float = 0.0) -> np.ndarray:
    """Draw the figure onto ``image`` (H,W,3) uint8 BGR in place; returns it."""
    j = humanoid_joints(cx, top, height, phase)
    u = height / 8.0
    thick = max(2, round(0.45 * u))

    def line(a, b, colour, width=thick):
        cv2.line(image, _pt(j[a]), _pt(j[b]), colour, width, cv2.LINE_AA)

    for side in ("r", "l"):
        line(f"{side}_hip", f"{side}_knee", _TROUSERS, int(thick * 1.3))
        line(f"{side}_knee", f"{side}_ankle", _TROUSERS, int(thick * 1.1))
        line(f"{side}_ankle", f"{side}_toe", (30, 30, 30), thick)
    torso = np.array([j["l_shoulder"], j["r_shoulder"], j["r_hip"], j["l_hip"]])
    cv2.fillConvexPoly(image, np.round(torso).astype(np.int32), _SHIRT, cv2.LINE_AA)
    line("neck", "pelvis", _SHIRT, thick * 2)
    for side in ("r", "l"):
        line(f"{side}_shoulder", f"{side}_elbow", _SHIRT, thick)
        line(f"{side}_elbow", f"{side}_wrist", _SKIN, int(thick * 0.9))
        cv2.circle(image, _pt(j[f"{side}_wrist"]), int(thick * 0.7), _SKIN, -1, cv2.LINE_AA)
    line("neck", "head", _SKIN, thick)
    head = j["head"]
    cv2.circle(image, _pt(head), int(0.55 * u), _SKIN, -1, cv2.LINE_AA)
    for dx in (-0.2, 0.2):
        cv2.circle(image, _pt(head + np.array([dx, -0.08]) * u), max(1, int(0.08 * u)), (20, 20, 20), -1, cv2.LINE_AA)
    cv2.ellipse(image, _pt(head + np.array([0, 0.25]) * u), (int(0.18 * u), int(0.06 * u)), 0, 0, 180, (40, 40, 120), 2)
    return image


def humanoid_frame(width: int, height: int, phase: float = 0.0, cx: float | None = None, seed: int = 0) -> np.ndarray:
    """One (height,width,3) uint8 BGR frame: light background, faint floor, a figure
    ~80 % of the frame tall centred at ``cx`` (default middle). Deterministic."""
    rng = np.random.default_rng(seed)
    frame = np.empty((height, width, 3), np.uint8)
    frame[:] = (205, 210, 215)
    frame[int(height * 0.9) :] = (150, 160, 170)
    # Some low-contrast clutter so the background is not perfectly flat.
    for _ in range(6):
        x, y = int(rng.integers(0, width)), int(rng.integers(0, int(height * 0.8)))
        size = int(rng.integers(height // 20, height // 8))
        colour = tuple(int(c) for c in rng.integers(170, 230, 3))
        cv2.rectangle(frame, (x, y), (x + size, y + size), colour, -1)
    figure_h = 0.8 * height
    draw_humanoid(frame, width / 2 if cx is None else cx, 0.08 * height, figure_h, phase)
    return frame


def write_walking_clip(
    path: str | Path, width: int = 1280, height: int = 720, n_frames: int = 60, fps: float = 30.0
) -> Path:
    """Write an mp4 (mp4v) of the figure walking in place while drifting sideways."""
    def frames():
        for i in range(n_frames):
            phase = 2 * math.pi * i / 30.0
            cx = width / 2 + 0.15 * width * math.sin(2 * math.pi * i / max(n_frames, 1))
            yield humanoid_frame(width, height, phase, cx)

    return write_mp4(frames(), path, fps, (width, height))


def _pt(p: np.ndarray) -> tuple[int, int]:
    return round(float(p[0])), round(float(p[1]))
