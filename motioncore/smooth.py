"""Spikes out (issue 50): a motion's joint accelerations held under a limit, the rest of it left as it is.

A frame where some joint accelerates faster than the limit (a window's seam, a guard's or an IK's jump) is drawn
towards the halfway pose of the frames either side of it (the first or last frame, where the next one spikes, towards
the straight line on from its neighbours): every joint's local rotation slerped, the root's position
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
        if not bool(bad[1:-1].any()):
            break
        # a spike at the second frame may be the first frame's (and so at the end): an end goes on in a straight line
        bad[0], bad[-1] = bool(bad[1]), bool(bad[-2])
        idx = bad.nonzero()[:, 0]
        inner = (idx > 0) & (idx < t - 1)
        near = torch.where(idx == 0, 1, torch.where(idx == t - 1, t - 2, idx + 1))  # inner: the next frame
        far = torch.where(idx == 0, 2, torch.where(idx == t - 1, t - 3, idx - 1))  # inner: the previous frame
        share = torch.where(inner, 0.5, 2.0)  # inner: halfway between; an end: past its neighbour, as far again
        mid_rot = quat.slerp(lrot[far], lrot[near], share[:, None])
        mid_pos = torch.lerp(lpos[far, 0], lpos[near, 0], share[:, None])
        lrot, lpos = lrot.clone(), lpos.clone()
        new = quat.slerp(lrot[idx], mid_rot, config.rate)
        lrot[idx] = new if frozen is None else torch.where(frozen[idx, :, None], lrot[idx], new)
        lpos[idx, 0] = torch.lerp(lpos[idx, 0], mid_pos, config.rate)
        changed = True
    return Motion(motion.skeleton, lrot, lpos, motion.fps) if changed else motion
