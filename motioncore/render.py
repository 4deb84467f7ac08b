"""Skeleton preview rendering: side-by-side panels of stick figures over a ground grid.

Each :class:`Panel` is drawn by a perspective camera of fixed orientation (from the
figure's front-right, looking down) that follows the figure's horizontal position through
a moving average, so walking figures stay centred without jitter. Positions are metres,
Y-up. Images are ``uint8`` BGR as OpenCV uses them.
"""
from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import torch

from motioncore.mp4 import write_mp4

BACKGROUND = (240, 238, 234)
GRID = (150, 150, 150)
SHADOW = (80, 80, 80)
LEFT, RIGHT, CENTRE = (40, 40, 215), (200, 120, 20), (60, 60, 60)  # BGR
_SHIFT = 4  # sub-pixel bits for cv2 drawing
_EYE = np.array([-1.9, 1.6, 2.8])  # camera offset from its target: front-right, up (~3.4 m)
_TARGET_Y = 0.85
_FOCAL = 1.4  # focal length in units of the image height (~39 degree vertical field of view)
_SMOOTH = 15  # camera moving-average half window, frames


def _side(name: str) -> int:
    """+1 left, -1 right, 0 centre, from ``*_L``/``*_R`` or ``Left*``/``Right*`` names."""
    n = name.split(":")[-1].split("|")[-1]
    if n.endswith("_L") or n.lower().startswith("left"):
        return 1
    if n.endswith("_R") or n.lower().startswith("right"):
        return -1
    return 0


@dataclass
class Panel:
    """One figure: ``positions (T, J, 3)`` metres Y-up (NaN = no pose), ``parents (J,)``."""

    positions: torch.Tensor
    parents: Sequence[int]
    label: str = ""
    color: tuple[int, int, int] | None = None  # BGR of centre bones (and all bones without names)
    names: Sequence[str] | None = None
    markers: torch.Tensor | None = None  # (T, J, 3) twist marker per bone (see twist_markers)
    colors: Sequence[tuple[int, int, int] | None] | None = None  # (J,) BGR per joint/bone, None: by side
    labels: Sequence[str] | None = None  # (J,) text drawn next to each joint ("" for none)
    eye: Sequence[float] | None = None  # the camera's offset (3,) metres from the point it looks at; None: front-right
    _pos: np.ndarray = field(init=False, repr=False)
    _track: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        pos = self.positions.detach().cpu().numpy() if isinstance(self.positions, torch.Tensor) else np.asarray(self.positions)
        j = len(self.parents)
        if pos.ndim != 3 or pos.shape[0] < 1 or pos.shape[1:] != (j, 3):
            raise ValueError(f"Panel: expected positions (T>=1, {j}, 3), got {tuple(pos.shape)}")
        if any(not -1 <= p < j for p in self.parents):
            raise ValueError(f"Panel: expected parents in [-1, {j}), got {list(self.parents)}")
        if self.names is not None and len(self.names) != j:
            raise ValueError(f"Panel: expected {j} names, got {len(self.names)}")
        for what, v in (("colors", self.colors), ("labels", self.labels)):
            if v is not None and len(v) != j:
                raise ValueError(f"Panel: expected {j} {what}, got {len(v)}")
        if self.markers is not None and tuple(self.markers.shape) != pos.shape:
            raise ValueError(f"Panel: expected markers {pos.shape}, got {tuple(self.markers.shape)}")
        if self.eye is not None and (np.shape(self.eye) != (3,) or not np.isfinite(self.eye).all()
                                     or np.hypot(self.eye[0], self.eye[2]) < 1e-3):
            raise ValueError(f"Panel: expected eye (3,) finite and off the vertical, got {self.eye}")
        self._pos = pos.astype(np.float64)
        self._marks = None if self.markers is None else self.markers.detach().cpu().numpy().astype(np.float64)
        self._track = _camera_track(self._pos)

    @property
    def num_frames(self) -> int:
        return self._pos.shape[0]


def _camera_track(pos: np.ndarray) -> np.ndarray:
    """``(T, J, 3) -> (T, 2)``: the figure's mean xz, NaN frames interpolated, moving-averaged."""
    with np.errstate(invalid="ignore"):
        xz = pos[:, :, [0, 2]].mean(axis=1)
    ok = np.isfinite(xz).all(axis=1)
    t = np.arange(len(xz))
    if not ok.any():
        return np.zeros((len(xz), 2))
    xz = np.stack([np.interp(t, t[ok], xz[ok, k]) for k in range(2)], axis=1)
    padded = np.pad(xz, ((_SMOOTH, _SMOOTH), (0, 0)), mode="edge")
    kernel = np.ones(2 * _SMOOTH + 1) / (2 * _SMOOTH + 1)
    return np.stack([np.convolve(padded[:, k], kernel, mode="valid") for k in range(2)], axis=1)


class _Camera:
    """Pinhole camera looking at ``(x, _TARGET_Y, z)`` from ``target + eye`` (default ``_EYE``)."""

    def __init__(self, x: float, z: float, w: int, h: int, eye: Sequence[float] | None = None):
        target = np.array([x, _TARGET_Y, z])
        self.eye = target + (_EYE if eye is None else np.asarray(eye, np.float64))
        f = target - self.eye
        f /= np.linalg.norm(f)
        r = np.cross(f, [0.0, 1.0, 0.0])
        r /= np.linalg.norm(r)
        self.rot = np.stack([r, np.cross(r, f), f])  # rows: screen right, screen up, forward
        self.w, self.h, self.focal = w, h, _FOCAL * h

    def to_camera(self, p: np.ndarray) -> np.ndarray:
        """World ``(*, 3)`` -> camera ``(*, 3)`` (x right, y up, z depth)."""
        return (p - self.eye) @ self.rot.T

    def to_pixels(self, c: np.ndarray) -> np.ndarray:
        """Camera ``(*, 3)`` with z > 0 -> fixed-point pixels ``(*, 2)`` int for cv2 with ``_SHIFT``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([self.w / 2 + self.focal * c[..., 0] / c[..., 2], self.h / 2 - self.focal * c[..., 1] / c[..., 2]], -1)
        return np.round(np.clip(np.nan_to_num(uv), -1e5, 1e5) * (1 << _SHIFT)).astype(np.int64)


def _draw_grid(img: np.ndarray, cam: _Camera, cx: float, cz: float, extent: float = 6.0, step: float = 0.5) -> None:
    """Lines every ``step`` m on y = 0 around ``(cx, cz)``, fading into the background with distance."""
    ticks_x = np.arange(np.floor((cx - extent) / step), np.ceil((cx + extent) / step) + 1) * step
    ticks_z = np.arange(np.floor((cz - extent) / step), np.ceil((cz + extent) / step) + 1) * step
    # Lines cut into step-long segments so that each can fade on its own: (N, 2 ends, 2 xz).
    x, z = (g.ravel() for g in np.meshgrid(ticks_x, ticks_z[:-1]))
    along_z = np.stack([np.stack([x, z], -1), np.stack([x, z + step], -1)], 1)
    x, z = (g.ravel() for g in np.meshgrid(ticks_x[:-1], ticks_z))
    along_x = np.stack([np.stack([x, z], -1), np.stack([x + step, z], -1)], 1)
    s = np.concatenate([along_z, along_x])
    world = np.stack([s[..., 0], np.zeros(s.shape[:2]), s[..., 1]], -1)
    dist = np.linalg.norm(s.mean(1) - [cx, cz], axis=1)
    fade = np.clip(1.0 - dist / extent, 0.0, 1.0) ** 1.5
    keep = fade > 0.02
    c, fade = cam.to_camera(world[keep]), fade[keep]  # (N, 2, 3)
    near = 0.1
    a, b = c[:, 0], c[:, 1]
    visible = (a[:, 2] >= near) | (b[:, 2] >= near)
    u = np.clip((near - a[:, 2]) / np.where(a[:, 2] == b[:, 2], 1.0, b[:, 2] - a[:, 2]), 0.0, 1.0)[:, None]
    a, b = np.where(a[:, 2:] < near, a + u * (b - a), a), np.where(b[:, 2:] < near, a + u * (b - a), b)  # near-plane clip
    pa, pb = cam.to_pixels(a), cam.to_pixels(b)
    colors = np.round(np.asarray(BACKGROUND) + fade[:, None] * (np.asarray(GRID) - BACKGROUND)).astype(int)
    for i in np.flatnonzero(visible):
        cv2.line(img, (int(pa[i, 0]), int(pa[i, 1])), (int(pb[i, 0]), int(pb[i, 1])), tuple(map(int, colors[i])), 1, cv2.LINE_AA, _SHIFT)


def twist_markers(grot: torch.Tensor, offsets: torch.Tensor, parents: Sequence[int]) -> torch.Tensor:
    """Per bone (its parent -> joint ``j``), a unit vector across the bone that turns with the parent joint,
    so a drawing shows the bone's twist: ``grot (T, J, 4)`` global rotations, ``offsets (J, 3)`` -> ``(T, J, 3)``."""
    from motioncore import quat

    if grot.shape[-2:] != (len(parents), 4) or tuple(offsets.shape) != (len(parents), 3):
        raise ValueError(f"twist_markers: expected grot (T, {len(parents)}, 4) and offsets ({len(parents)}, 3), "
                         f"got {tuple(grot.shape)} and {tuple(offsets.shape)}")
    off = offsets.double()
    least = torch.nn.functional.one_hot(off.abs().argmin(-1), 3).double()  # the axis the bone is least along
    across = torch.nn.functional.normalize(torch.linalg.cross(off, least), dim=-1)
    par = [max(p, 0) for p in parents]
    return quat.mul_vec(grot[:, par].double(), across.expand(grot.shape[0], -1, -1)).float()


def _draw_figure(img: np.ndarray, panel: Panel, pose: np.ndarray, cam: _Camera, marks: np.ndarray | None = None) -> None:
    """Shadow on y = 0, then bones and joints of ``pose (J, 3)``, far to near."""
    h = img.shape[0]
    thick = max(2, h // 90)
    bones = [(j, p) for j, p in enumerate(panel.parents) if p >= 0]
    shadow = pose * [1.0, 0.0, 1.0]
    overlay = img.copy()
    sc = cam.to_camera(shadow)
    sp = cam.to_pixels(sc)
    for j, p in bones:
        if sc[j, 2] > 0.1 and sc[p, 2] > 0.1:
            cv2.line(overlay, tuple(map(int, sp[j])), tuple(map(int, sp[p])), SHADOW, thick + 2, cv2.LINE_AA, _SHIFT)
    cv2.addWeighted(overlay, 0.35, img, 0.65, 0.0, dst=img)

    c = cam.to_camera(pose)
    if (c[:, 2] <= 0.1).any():
        return
    px = cam.to_pixels(c)
    centre = panel.color or CENTRE
    sides = [_side(n) for n in panel.names] if panel.names is not None else [0] * len(panel.parents)
    palette = {1: LEFT, -1: RIGHT, 0: centre}
    colors = [palette[s] if panel.colors is None or panel.colors[j] is None else panel.colors[j] for j, s in enumerate(sides)]
    items = [(c[j, 2] + c[p, 2], "bone", j, p) for j, p in bones] + [(2 * c[j, 2] - 1e-3, "joint", j, j) for j in range(len(pose))]
    for _, kind, j, p in sorted(items, key=lambda it: -it[0]):
        color = colors[j]
        dark = tuple(int(v * 0.6) for v in color)
        if kind == "bone":
            cv2.line(img, tuple(map(int, px[j])), tuple(map(int, px[p])), color, thick, cv2.LINE_AA, _SHIFT)
            length = float(np.linalg.norm(pose[j] - pose[p]))
            if marks is not None and length > 0.04:  # a fin across the bone at its middle: shows the twist
                mid = (pose[j] + pose[p]) / 2
                fin = cam.to_pixels(cam.to_camera(np.stack([mid, mid + marks[j] * min(0.08, 0.35 * length)])))
                cv2.line(img, tuple(map(int, fin[0])), tuple(map(int, fin[1])), dark, max(1, thick // 2), cv2.LINE_AA, _SHIFT)
        else:
            cv2.circle(img, tuple(map(int, px[j])), int(thick * 0.9 * (1 << _SHIFT)), dark, -1, cv2.LINE_AA, _SHIFT)
    if panel.labels is not None:
        scale = img.shape[0] / 1400
        for j, text in enumerate(panel.labels):
            if text:
                x, y = (int(v) >> _SHIFT for v in px[j])
                _text(img, text, (x + 6, y - 4), scale, tuple(int(v * 0.5) for v in colors[j]))


def _text(img: np.ndarray, s: str, org: tuple[int, int], scale: float, color=(30, 30, 30)) -> None:
    cv2.putText(img, s, org, cv2.FONT_HERSHEY_SIMPLEX, scale, color, 1, cv2.LINE_AA)


def _render_panel(panel: Panel, t: int, w: int, h: int, fps: float | None) -> np.ndarray:
    """One ``(h, w, 3)`` uint8 BGR panel at frame ``t`` (held at the panel's last frame)."""
    k = min(t, panel.num_frames - 1)
    img = np.empty((h, w, 3), np.uint8)
    img[:] = BACKGROUND
    cx, cz = panel._track[k]
    cam = _Camera(cx, cz, w, h, panel.eye)
    _draw_grid(img, cam, cx, cz)
    pose = panel._pos[k]
    scale = h / 800
    if np.isfinite(pose).all():
        _draw_figure(img, panel, pose, cam, None if panel._marks is None else panel._marks[k])
    else:
        (tw, _), _ = cv2.getTextSize("no pose", cv2.FONT_HERSHEY_SIMPLEX, 3 * scale, 1)
        _text(img, "no pose", ((w - tw) // 2, h // 2), 3 * scale, (70, 70, 70))
    _text(img, panel.label, (8, int(30 * scale) + 8), 1.3 * scale)
    info = f"frame {k + 1}/{panel.num_frames}" + (f"  {k / fps:.2f} s" if fps else "")
    _text(img, info, (8, int(70 * scale) + 10), 1.0 * scale, (90, 90, 90))
    return img


def _check_size(size: Sequence[int]) -> tuple[int, int]:
    if len(size) != 2 or any(int(v) != v or v < 16 for v in size):
        raise ValueError(f"expected size (W, H) of integers >= 16, got {tuple(size)}")
    return int(size[0]), int(size[1])


def render_frame(panels: Sequence[Panel], t: int, size: tuple[int, int] = (480, 480), fps: float | None = None) -> np.ndarray:
    """Frame ``t`` of all panels side by side: ``(H, W * len(panels), 3)`` uint8 BGR.

    Panels shorter than ``t + 1`` frames hold their last frame; ``fps`` adds the time in seconds.
    """
    w, h = _check_size(size)
    if not panels:
        raise ValueError("expected at least one panel, got 0")
    if t < 0:
        raise ValueError(f"expected frame index t >= 0, got {t}")
    imgs = [_render_panel(p, t, w, h, fps) for p in panels]
    for img in imgs[1:]:
        img[:, 0] = (120, 120, 120)  # separator
    return np.concatenate(imgs, axis=1)


def render_video(panels: Sequence[Panel], out_path: str | os.PathLike, fps: float, size: tuple[int, int] = (480, 480), progress: bool = True) -> Path:
    """Write all frames (the longest panel's length) to an MPEG-4 ``.mp4`` atomically; returns the path.

    ``size`` is one panel's (W, H); both must be even (the encoder drops odd rows/columns).
    """
    w, h = _check_size(size)
    if w % 2 or h % 2:
        raise ValueError(f"expected an even panel size (W, H), got {(w, h)}")
    if not fps > 0:
        raise ValueError(f"expected fps > 0, got {fps}")
    if not panels:
        raise ValueError("expected at least one panel, got 0")
    out = Path(out_path)
    n = max(p.num_frames for p in panels)

    def frames():
        for t in range(n):
            yield render_frame(panels, t, (w, h), fps)
            if progress and (t + 1 == n or t % max(1, n // 10) == 0):
                print(f"\rrendering {out.name}: frame {t + 1}/{n}", end="\n" if t + 1 == n else "", file=sys.stderr, flush=True)

    return write_mp4(frames(), out, fps, (w * len(panels), h))
