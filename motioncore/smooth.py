"""Spikes out (issue 50): a motion's joint accelerations held under a limit, the rest of it left as it is.

A frame where some joint accelerates faster than the limit (a window's seam, a guard's or an IK's jump) is drawn
towards the halfway pose of the frames either side of it: every joint's local rotation slerped, the root's position
lerped, by :attr:`SpikeConfig.rate`, and again on the next pass while a frame is still over the limit (at most
:attr:`SpikeConfig.passes` passes). Frames under the limit are never touched, so a smooth motion comes back
unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from motioncore import quat
from motioncore.kinematics import fk
from motioncore.motion import Motion


@dataclass(frozen=True)
class SpikeConfig:
    """How :func:`limit_acceleration` draws spikes out."""

    passes: int = 40  # at most this many passes over the motion
    rate: float = 0.5  # the share of the way to the neighbours' halfway pose a spiking frame moves per pass


def joint_accelerations(gpos: torch.Tensor, fps: float) -> torch.Tensor:
    """``(T, J)`` m/s²: each joint's acceleration at each frame of positions ``gpos (T, J, 3)`` (second differences;
    the first and last frames 0)."""
    if gpos.ndim != 3 or gpos.shape[-1] != 3:
        raise ValueError(f"joint_accelerations: expected positions (T, J, 3), got {tuple(gpos.shape)}")
    out = torch.zeros(gpos.shape[:2], dtype=gpos.dtype)
    if gpos.shape[0] >= 3:
        out[1:-1] = (gpos[2:] - 2 * gpos[1:-1] + gpos[:-2]).norm(dim=-1) * fps * fps
    return out


def limit_acceleration(motion: Motion, limit: float, config: SpikeConfig = SpikeConfig(),
                       frozen: torch.Tensor | None = None) -> Motion:
    """``motion`` with its frames whose peak joint acceleration exceeds ``limit`` (m/s²) smoothed until none does or
    the passes run out (see the module's docstring). ``frozen (T, J)`` bool: local rotations never changed (e.g. a
    planted leg's, which the foot cleanup solved). Returns ``motion`` itself when nothing exceeds the limit."""
    if not limit > 0:
        raise ValueError(f"limit_acceleration: expected a limit > 0, got {limit}")
    t = motion.num_frames
    if frozen is not None and frozen.shape != (t, motion.skeleton.num_joints):
        raise ValueError(f"limit_acceleration: expected frozen ({t}, {motion.skeleton.num_joints}), "
                         f"got {tuple(frozen.shape)}")
    if t < 3:
        return motion
    parents = motion.skeleton.parents
    lrot, lpos = motion.lrot, motion.lpos
    changed = False
    for _ in range(max(0, int(config.passes))):
        acc = joint_accelerations(fk(lrot, lpos, parents)[1], motion.fps).amax(1)  # (T,)
        bad = acc > limit
        bad[0] = bad[-1] = False
        if not bool(bad.any()):
            break
        idx = bad.nonzero()[:, 0]
        mid_rot = quat.slerp(lrot[idx - 1], lrot[idx + 1], 0.5)
        mid_pos = 0.5 * (lpos[idx - 1, 0] + lpos[idx + 1, 0])
        lrot, lpos = lrot.clone(), lpos.clone()
        new = quat.slerp(lrot[idx], mid_rot, config.rate)
        lrot[idx] = new if frozen is None else torch.where(frozen[idx, :, None], lrot[idx], new)
        lpos[idx, 0] = torch.lerp(lpos[idx, 0], mid_pos, config.rate)
        changed = True
    return Motion(motion.skeleton, lrot, lpos, motion.fps) if changed else motion
