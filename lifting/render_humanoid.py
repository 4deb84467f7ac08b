"""Render a canonical motion as a video of a simple humanoid seen by a static pinhole camera.

The figure has body volume so that a person detector takes it for a person: thick limbs
(lines whose width follows the perspective), a torso polygon, shoes, hands, and a round head
with two eyes and a mouth on the side its ``Head`` joint faces. Parts are painted far to
near. Used to measure the lifting pipeline against known 3-D truth
(``benchmarks/bench_pose.py --accuracy``) and by the tests.

Coordinates: world Y-up metres (the canonical convention). The camera is OpenCV-like:
x right, y down, z forward; pixels with the origin at the top-left corner.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from motioncore import quat
from motioncore.kinematics import fk
from motioncore.motion import Motion
from motioncore.mp4 import write_mp4
from motioncore.skeleton import CANONICAL

SKIN = (140, 170, 215)  # BGR
SHIRT = (150, 80, 40)
TROUSERS = (60, 60, 70)
SHOES = (25, 25, 25)
HAIR = (30, 45, 70)
BACKGROUND = (200, 205, 210)
FLOOR = (150, 160, 165)
_SHIFT = 4

# (joint a, joint b, radius m, colour)
_LIMBS = [
    ("UpperLeg_{s}", "LowerLeg_{s}", 0.075, TROUSERS),
    ("LowerLeg_{s}", "Foot_{s}", 0.058, TROUSERS),
    ("UpperArm_{s}", "LowerArm_{s}", 0.055, SHIRT),
    ("LowerArm_{s}", "Hand_{s}", 0.042, SKIN),
]


@dataclass(frozen=True)
class Camera:
    """Static pinhole camera at ``eye`` looking at ``target`` (world, Y-up), ``fov_deg`` across the
    image width, no lens distortion, principal point at the image centre."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    width: int = 1280
    height: int = 720
    fov_deg: float = 60.0

    @property
    def focal(self) -> float:
        return 0.5 * self.width / math.tan(math.radians(self.fov_deg) / 2)

    @property
    def rotation(self) -> np.ndarray:
        """``(3, 3)`` rows: camera x (right), y (down), z (forward) in world coordinates."""
        f = np.subtract(self.target, self.eye).astype(np.float64)
        f /= np.linalg.norm(f)
        r = np.cross(f, [0.0, 1.0, 0.0])
        r /= np.linalg.norm(r)
        down = np.cross(f, r)
        return np.stack([r, down, f])

    def to_camera(self, p: np.ndarray) -> np.ndarray:
        """World ``(*, 3)`` -> camera ``(*, 3)`` (x right, y down, z depth)."""
        return (np.asarray(p, np.float64) - np.asarray(self.eye)) @ self.rotation.T

    def project(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World ``(*, 3)`` -> pixels ``(*, 2)`` and depth ``(*)``."""
        c = self.to_camera(p)
        z = np.maximum(c[..., 2], 1e-6)
        uv = np.stack([0.5 * self.width + self.focal * c[..., 0] / z, 0.5 * self.height + self.focal * c[..., 1] / z], -1)
        return uv, c[..., 2]


def frame_camera(positions: np.ndarray, azimuth_deg: float, width: int = 1280, height: int = 720,
                 fov_deg: float = 60.0, eye_height: float = 1.5, min_distance: float = 4.0,
                 margin: float = 0.06) -> Camera:
    """A static camera at ``azimuth_deg`` around +Z (0 = in front of a figure facing +Z, 90 = at its
    left side) that keeps every joint of ``positions (T, J, 3)`` inside the frame."""
    pos = np.asarray(positions, np.float64)
    lo, hi = pos.reshape(-1, 3).min(0), pos.reshape(-1, 3).max(0)
    centre = 0.5 * (lo + hi)
    target = (float(centre[0]), 0.9, float(centre[2]))
    a = math.radians(azimuth_deg)
    direction = np.array([math.sin(a), 0.0, math.cos(a)])
    pad = np.array([0.25, 0.2, 0.25])  # limb and head volume around the joints
    corners = np.array([[x, y, z] for x in (lo[0] - pad[0], hi[0] + pad[0]) for y in (lo[1] - 0.1, hi[1] + pad[1])
                        for z in (lo[2] - pad[2], hi[2] + pad[2])])
    dist = min_distance
    for _ in range(200):
        eye = (target[0] + dist * direction[0], eye_height, target[2] + dist * direction[2])
        cam = Camera(eye, target, width, height, fov_deg)
        uv, z = cam.project(corners)
        inside = (z > 0.5).all() and (uv[:, 0] > margin * width).all() and (uv[:, 0] < (1 - margin) * width).all() \
            and (uv[:, 1] > margin * height).all() and (uv[:, 1] < (1 - margin) * height).all()
        if inside:
            return cam
        dist += 0.25
    return cam


def _shade(colour: tuple[int, int, int], k: float) -> tuple[int, int, int]:
    return tuple(int(min(255, c * k)) for c in colour)


def _px(uv: np.ndarray) -> tuple[int, int]:
    return round(uv[0] * (1 << _SHIFT)), round(uv[1] * (1 << _SHIFT))


def draw_humanoid(img: np.ndarray, cam: Camera, pos: np.ndarray, head_rot: np.ndarray) -> None:
    """Paint one pose ``pos (21, 3)`` (canonical joints, world) with ``head_rot (3, 3)`` (the Head
    joint's global rotation matrix) onto ``img`` in place."""
    names = CANONICAL.skeleton.names
    p = {n: pos[i] for i, n in enumerate(names)}
    parts: list[tuple[float, object]] = []

    def capsule(a: np.ndarray, b: np.ndarray, radius: float, colour) -> None:
        uv, z = cam.project(np.stack([a, b]))
        if (z < 0.2).any():
            return
        width = max(2, round(2 * radius * cam.focal / z.mean()))
        a, b = _px(uv[0]), _px(uv[1])

        def draw() -> None:  # a rounded cylinder: dark rim, body colour, highlight
            cv2.line(img, a, b, _shade(colour, 0.65), width, cv2.LINE_AA, _SHIFT)
            cv2.line(img, a, b, colour, max(1, int(width * 0.7)), cv2.LINE_AA, _SHIFT)
            cv2.line(img, a, b, _shade(colour, 1.25), max(1, int(width * 0.25)), cv2.LINE_AA, _SHIFT)

        parts.append((float(z.mean()), draw))

    def disc(c: np.ndarray, radius: float, colour, depth_bias: float = 0.0) -> None:
        uv, z = cam.project(c[None])
        if z[0] < 0.2:
            return
        r = max(1.0, radius * cam.focal / z[0])
        parts.append((float(z[0]) + depth_bias,
                      lambda: cv2.circle(img, _px(uv[0]), round(r * (1 << _SHIFT)), colour, -1, cv2.LINE_AA, _SHIFT)))

    for side in ("L", "R"):
        for a, b, r, colour in _LIMBS:
            capsule(p[a.format(s=side)], p[b.format(s=side)], r, colour)
        foot, toes = p[f"Foot_{side}"], p[f"Toes_{side}"]
        tip = toes + 0.6 * (toes - foot) * np.array([1.0, 0.0, 1.0])
        tip[1] = max(tip[1], toes[1] - 0.01)
        capsule(foot, tip, 0.045, SHOES)
        hand, elbow = p[f"Hand_{side}"], p[f"LowerArm_{side}"]
        d = (hand - elbow) / max(np.linalg.norm(hand - elbow), 1e-6)
        disc(hand + 0.05 * d, 0.05, SKIN)

    # Torso: a shaded polygon from the shoulders' outer edges to the hips', with a thick spine for volume.
    lat = p["UpperLeg_L"] - p["UpperLeg_R"]
    lat = lat / max(np.linalg.norm(lat), 1e-6)
    sh = p["UpperArm_L"] - p["UpperArm_R"]
    sh = sh / max(np.linalg.norm(sh), 1e-6)
    waist = 0.5 * (p["Spine"] + p["Hips"])
    quad = np.stack([p["UpperArm_L"] + 0.04 * sh, p["UpperArm_R"] - 0.04 * sh, waist - 0.13 * lat,
                     p["UpperLeg_R"] - 0.08 * lat, p["UpperLeg_L"] + 0.08 * lat, waist + 0.13 * lat])
    uv, z = cam.project(quad)
    if (z > 0.2).all():
        pts = np.round(uv * (1 << _SHIFT)).astype(np.int32)
        inner = np.round((uv + 0.25 * (uv.mean(0) - uv)) * (1 << _SHIFT)).astype(np.int32)

        def torso() -> None:
            cv2.fillPoly(img, [pts], _shade(SHIRT, 0.7), cv2.LINE_AA, _SHIFT)
            cv2.fillPoly(img, [inner], SHIRT, cv2.LINE_AA, _SHIFT)

        parts.append((float(z.mean()) + 0.01, torso))
    capsule(p["Hips"], p["Chest"], 0.12, SHIRT)
    capsule(p["Chest"], p["Neck"], 0.11, SHIRT)
    capsule(p["Neck"], p["Head"], 0.05, SKIN)

    # Head: a disc above the Head joint; eyes and mouth on the side it faces, when visible.
    up, fwd, left = head_rot[:, 1], head_rot[:, 2], head_rot[:, 0]
    centre = p["Head"] + 0.07 * up
    disc(centre - 0.03 * fwd + 0.01 * up, 0.105, HAIR)  # hair at the back, face at the front
    disc(centre + 0.02 * fwd - 0.01 * up, 0.1, SKIN)
    to_cam = np.asarray(cam.eye) - centre
    facing = float(fwd @ to_cam / np.linalg.norm(to_cam))
    if facing > -0.1:
        for s in (1.0, -1.0):
            disc(centre + 0.09 * fwd + 0.04 * s * left + 0.025 * up, 0.016, (30, 30, 30), -0.2)
        disc(centre + 0.1 * fwd - 0.04 * up, 0.012, (60, 60, 140), -0.2)
    for _, draw in sorted(parts, key=lambda it: -it[0]):
        draw()


def background(cam: Camera) -> np.ndarray:
    """The empty scene: a wall colour above the horizon and a floor below it."""
    img = np.empty((cam.height, cam.width, 3), np.uint8)
    img[:] = BACKGROUND
    rot = cam.rotation
    # Horizon: image row where the viewing ray is horizontal (camera pitch).
    pitch = math.asin(float(np.clip(-rot[2, 1], -1, 1)))
    row = int(np.clip(0.5 * cam.height - cam.focal * math.tan(pitch), 0, cam.height))
    img[row:] = FLOOR
    return img


def render_frames(motion: Motion, cam: Camera) -> Iterator[np.ndarray]:
    """``(H, W, 3)`` uint8 BGR frames of a canonical ``motion`` seen by ``cam``, one at a time."""
    grot, gpos = fk(motion.lrot, motion.lpos, motion.skeleton.parents)
    head = quat.to_matrix(grot[:, motion.skeleton.index("Head")]).numpy().astype(np.float64)
    gpos = gpos.numpy().astype(np.float64)
    base = background(cam)
    for t in range(motion.num_frames):
        img = base.copy()
        draw_humanoid(img, cam, gpos[t], head[t])
        yield img


def write_humanoid_video(motion: Motion, cam: Camera, path: str | os.PathLike) -> Path:
    """Write the render of ``motion`` (at its own fps) to an mp4 (mp4v) atomically."""
    return write_mp4(render_frames(motion, cam), path, motion.fps, (cam.width, cam.height))
