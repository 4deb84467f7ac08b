"""Helpers the lifting tests share: a synthetic waving motion and its frame size, landmarks of a person standing
upright, turned frames' pixels, a tracker's result made from landmarks."""
from __future__ import annotations

import math

import numpy as np
import torch

from lifting.blazepose.results import POSE_LANDMARKS
from motioncore import quat
from motioncore.ik_fit import default_reference
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL

W, H = 640, 360  # the synthetic videos' frame size
SK = CANONICAL.skeleton


def waving_motion(seconds: float = 1.6, fps: float = 30.0) -> Motion:
    """The reference (mean) pose standing at the origin facing +Z, waving the right arm and
    bending the knees a little."""
    n = round(seconds * fps)
    t = torch.arange(n) / fps
    lrot = default_reference().expand(n, -1, -1).clone()
    wave = quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]).expand(n, 3), -1.4 + 0.5 * torch.sin(2 * math.pi * 1.2 * t))
    lrot[:, SK.index("UpperArm_R")] = quat.mul(lrot[:, SK.index("UpperArm_R")], wave)
    lpos = SK.offsets.expand(n, -1, -1).clone()
    lpos[:, 0, 1] = 0.93
    return Motion(SK, lrot, lpos, fps)


def standing_landmarks(n: int = 10) -> np.ndarray:
    """(n,33,3) pixels of a person standing upright: shoulders at y=100, hips at 200, ankles at 300."""
    pts = np.zeros((n, len(POSE_LANDMARKS), 3), np.float32)
    for name, y in (("shoulder", 100), ("hip", 200), ("ankle", 300)):
        pts[:, POSE_LANDMARKS.index(f"left_{name}")] = (310, y, 0)
        pts[:, POSE_LANDMARKS.index(f"right_{name}")] = (330, y, 0)
    return pts


def turned_pixels(pts: np.ndarray, turn: int, width: int = 640, height: int = 360) -> np.ndarray:
    """Landmark pixels of a ``width`` x ``height`` frame after turning the frame ``turn`` degrees clockwise."""
    x, y = pts[..., 0], pts[..., 1]
    new = {0: (x, y), 90: (height - 1 - y, x), 180: (width - 1 - x, height - 1 - y), 270: (y, width - 1 - x)}[turn]
    return np.stack([*new, pts[..., 2]], -1)


def fake_track(image: np.ndarray, found: np.ndarray | None = None):
    from lifting.blazepose.results import TrackResult

    n = len(image)
    found = np.ones(n, bool) if found is None else found
    return TrackResult(world=np.zeros_like(image), image=image, visibility=np.ones((n, 33)), presence=np.ones((n, 33)),
                       score=np.ones(n), found=found, times=np.arange(n) / 30.0, fps=30.0, width=640, height=360)
