"""A motion on a skeleton: local rotations and local positions per frame."""
from __future__ import annotations

from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import fk
from motioncore.skeleton import CANONICAL, CanonicalSpec, Skeleton


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
    n_out = max(1, round((motion.num_frames - 1) * fps / motion.fps) + 1)
    t = torch.arange(n_out, dtype=torch.float64) * (motion.fps / fps)
    t = t.clamp(max=motion.num_frames - 1)
    i0 = t.floor().long().clamp(max=motion.num_frames - 1)
    i1 = (i0 + 1).clamp(max=motion.num_frames - 1)
    w = (t - i0).float()
    lrot = quat.slerp(motion.lrot[i0], motion.lrot[i1], w[:, None])
    lpos = motion.lpos[i0] + (motion.lpos[i1] - motion.lpos[i0]) * w[:, None, None]
    return Motion(motion.skeleton, lrot, lpos, fps)


def mirror(motion: Motion, spec: CanonicalSpec = CANONICAL) -> Motion:
    """Reflect a canonical motion across the YZ plane (x -> -x) and swap left/right joints."""
    if motion.skeleton is not spec.skeleton and motion.skeleton.names != spec.skeleton.names:
        raise ValueError("mirror: expected a motion on the canonical skeleton")
    idx = list(spec.mirror)
    lrot = motion.lrot[:, idx] * motion.lrot.new_tensor([1.0, 1.0, -1.0, -1.0])
    lpos = motion.lpos[:, idx] * motion.lpos.new_tensor([-1.0, 1.0, 1.0])
    return Motion(motion.skeleton, lrot, lpos, motion.fps)
