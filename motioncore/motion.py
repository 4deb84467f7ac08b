"""A motion on a skeleton: local rotations and local positions per frame."""
from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import fk
from motioncore.skeleton import CANONICAL, CanonicalSpec, Skeleton
from motioncore.span import Span, check_span, frame_at


@dataclass
class Motion:
    """``lrot (T, J, 4)`` wxyz and ``lpos (T, J, 3)`` metres (root: global position), float32."""

    skeleton: Skeleton
    lrot: torch.Tensor
    lpos: torch.Tensor
    fps: float

    def __post_init__(self) -> None:
        j = self.skeleton.num_joints
        if self.lrot.ndim != 3 or self.lrot.shape[1:] != (j, 4):
            raise ValueError(f"Motion: expected lrot (T, {j}, 4), got {tuple(self.lrot.shape)}")
        if self.lpos.shape != self.lrot.shape[:2] + (3,):
            raise ValueError(f"Motion: expected lpos (T, {j}, 3), got {tuple(self.lpos.shape)}")
        if not self.fps > 0:
            raise ValueError(f"Motion: expected fps > 0, got {self.fps}")
        self.lrot = self.lrot.float()
        self.lpos = self.lpos.float()

    @property
    def num_frames(self) -> int:
        return self.lrot.shape[0]

    @property
    def duration(self) -> float:
        return self.num_frames / self.fps

    def global_positions(self) -> torch.Tensor:
        """``(T, J, 3)`` metres."""
        return fk(self.lrot, self.lpos, self.skeleton.parents)[1]

    def slice(self, start: int, stop: int) -> Motion:
        return Motion(self.skeleton, self.lrot[start:stop], self.lpos[start:stop], self.fps)


def resample(motion: Motion, fps: float) -> Motion:
    """Resample to ``fps`` by slerp (rotations) and lerp (positions) over the same duration."""
    if abs(fps - motion.fps) < 1e-9:
        return motion
    return resample_span(motion, fps, 0, resampled_frames(motion.num_frames, motion.fps, fps))


def resampled_frames(frames: int, fps: float, to_fps: float) -> int:
    """How many frames :func:`resample` makes of ``frames`` frames at ``fps``, resampled to ``to_fps``."""
    return frames if abs(to_fps - fps) < 1e-9 else max(1, round((frames - 1) * to_fps / fps) + 1)


def resample_span(motion: Motion, fps: float, start: int, stop: int, first: int = 0, total: int | None = None) -> Motion:
    """Frames ``start..stop-1`` of :func:`resample` of a take of ``total`` frames (default: ``motion``'s), of
    which ``motion`` holds frames ``first..``: a long take is resampled a span at a time, the same values. Raises
    when ``motion`` lacks a frame the span interpolates from."""
    total = motion.num_frames if total is None else total
    lrot = torch.empty(stop - start, *motion.lrot.shape[1:])
    lpos = torch.empty(stop - start, *motion.lpos.shape[1:])
    for a in range(start, stop, _CHUNK):  # a chunk of frames at a time: a long take's temporaries stay small
        t = torch.arange(a, min(a + _CHUNK, stop), dtype=torch.float64) * (motion.fps / fps)
        t = t.clamp(max=total - 1)
        i0 = t.floor().long().clamp(max=total - 1)
        i1 = (i0 + 1).clamp(max=total - 1)
        w = (t - i0).float()
        i0, i1 = i0 - first, i1 - first
        if int(i0[0]) < 0 or int(i1[-1]) >= motion.num_frames:
            raise ValueError(f"resample_span: expected frames {first + int(i0[0])}-{first + int(i1[-1])} of the take, "
                             f"got {first}-{first + motion.num_frames - 1}")
        z = slice(a - start, a - start + len(t))
        lrot[z] = quat.slerp(motion.lrot[i0], motion.lrot[i1], w[:, None])
        lpos[z] = motion.lpos[i0] + (motion.lpos[i1] - motion.lpos[i0]) * w[:, None, None]
    return Motion(motion.skeleton, lrot, lpos, fps)


_CHUNK = 5_000


def mirror(motion: Motion, spec: CanonicalSpec = CANONICAL) -> Motion:
    """Reflect a canonical motion across the YZ plane (x -> -x) and swap left/right joints."""
    if motion.skeleton is not spec.skeleton and motion.skeleton.names != spec.skeleton.names:
        raise ValueError("mirror: expected a motion on the canonical skeleton")
    idx = list(spec.mirror)
    lrot = motion.lrot[:, idx] * motion.lrot.new_tensor([1.0, 1.0, -1.0, -1.0])
    lpos = motion.lpos[:, idx] * motion.lpos.new_tensor([-1.0, 1.0, 1.0])
    return Motion(motion.skeleton, lrot, lpos, motion.fps)


def trim(motion: Motion, span: Span, source: str) -> Motion:
    """The frames of ``motion`` with ``start <= time < end`` (``span`` in seconds, None = open end)."""
    start, end = check_span(span, source)
    first = 0 if start is None else frame_at(start, motion.fps, motion.num_frames)
    stop = motion.num_frames if end is None else frame_at(end, motion.fps, motion.num_frames)
    if first >= stop:
        raise ValueError(f"{source}: --start/--end select no frames (the clip is {motion.duration:.2f} s long)")
    return motion.slice(first, stop)


def time_warp(motion: Motion, tempo: float) -> Motion:
    """The same poses played ``tempo`` times as fast (0.8: 25 % more frames, slower), same fps and path."""
    if not (math.isfinite(tempo) and 0.25 <= tempo <= 4):
        raise ValueError(f"time_warp: expected a tempo from 0.25 to 4, got {tempo}")
    warped = resample(motion, motion.fps / tempo)
    return Motion(motion.skeleton, warped.lrot, warped.lpos, motion.fps)


def root_speed(motion: Motion) -> float:
    """Mean horizontal speed of the root (m/s): the length of its ground path over the clip's duration."""
    xz = motion.lpos[:, 0, [0, 2]].double()
    if xz.shape[0] < 2:
        return 0.0
    return float((xz[1:] - xz[:-1]).norm(dim=-1).sum() / ((xz.shape[0] - 1) / motion.fps))
