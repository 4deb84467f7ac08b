"""Foot-skate cleanup: pin contacts, solve the legs with analytic two-bone IK.

Contacts come from a reference motion (the content clip the result is aligned with). Each run
of ankle contact frames is pinned to its mean position in the result, with smoothstep blending
in and out; the ankle is kept above the floor; hips stay where they are; each leg is solved so
the ankle reaches its target with the knee bending in its current plane, and the foot keeps its
global orientation; where that orientation would put its toes through the floor (a style that lowers the body keeps
the content's toe-off pitch), the ankle is lifted until they touch it.
"""
from __future__ import annotations

import torch

from motioncore import quat
from motioncore.kinematics import fk, rest_positions
from motioncore.motion import Motion
from motioncore.representation import foot_contacts
from motioncore.skeleton import CANONICAL, CanonicalSpec


def contact_runs(flags: torch.Tensor) -> list[tuple[int, int]]:
    """``flags (T,)`` bool -> list of ``[start, stop)`` runs of True."""
    runs, start = [], None
    for i, f in enumerate(flags.tolist() + [False]):
        if f and start is None:
            start = i
        elif not f and start is not None:
            runs.append((start, i))
            start = None
    return runs


def ankle_targets(ankle: torch.Tensor, flags: torch.Tensor, blend: int, floor: float) -> torch.Tensor:
    """Pinned targets ``(T, 3)`` for one ankle trajectory ``(T, 3)`` given contact ``flags (T,)``."""
    target = ankle.clone()
    weight = torch.zeros(ankle.shape[0])
    pinned = ankle.clone()
    for s, e in contact_runs(flags.bool()):
        mean = ankle[s:e].mean(0)
        lo, hi = max(0, s - blend), min(ankle.shape[0], e + blend)
        for i in range(lo, hi):
            if s <= i < e:
                w = 1.0
            else:
                d = (s - i) if i < s else (i - e + 1)
                x = 1.0 - d / (blend + 1)
                w = x * x * (3 - 2 * x)  # smoothstep ease
            if w > weight[i]:
                weight[i] = w
                pinned[i] = mean
    target = ankle + weight[:, None] * (pinned - ankle)
    target[:, 1] = target[:, 1].clamp_min(floor)
    return target


def two_bone_ik(grot: torch.Tensor, gpos: torch.Tensor, lrot: torch.Tensor, parents, hip: int, knee: int, ankle: int,
                target: torch.Tensor) -> torch.Tensor:
    """New local rotations ``(T, J, 4)`` so the ``ankle`` reaches ``target (T, 3)``; foot keeps its global rotation."""
    h, k, a = gpos[:, hip], gpos[:, knee], gpos[:, ankle]
    l1 = (k - h).norm(dim=-1, keepdim=True)
    l2 = (a - k).norm(dim=-1, keepdim=True)
    to_t = target - h
    d = to_t.norm(dim=-1, keepdim=True).clamp(min=(l1 - l2).abs() + 1e-4, max=l1 + l2 - 1e-4)
    u = torch.nn.functional.normalize(to_t, dim=-1)
    bend = (k - h) - ((k - h) * torch.nn.functional.normalize(a - h, dim=-1)).sum(-1, keepdim=True) * torch.nn.functional.normalize(a - h, dim=-1)
    pole = bend - (bend * u).sum(-1, keepdim=True) * u
    fallback = quat.mul_vec(grot[:, hip], torch.tensor([0.0, 0.0, 1.0]).expand_as(pole))  # knee forward
    fallback = fallback - (fallback * u).sum(-1, keepdim=True) * u
    pole = torch.where(pole.norm(dim=-1, keepdim=True) < 1e-5, fallback, pole)
    pole = torch.nn.functional.normalize(pole, dim=-1)
    x = (l1**2 - l2**2 + d**2) / (2 * d)
    y = (l1**2 - x**2).clamp_min(0).sqrt()
    knee_new = h + x * u + y * pole
    ankle_new = h + d * u

    swing_hip = quat.between(k - h, knee_new - h)
    g_hip = quat.mul(swing_hip, grot[:, hip])
    shank = quat.mul_vec(swing_hip, a - k)
    g_knee = quat.mul(quat.between(shank, ankle_new - knee_new), quat.mul(swing_hip, grot[:, knee]))
    out = lrot.clone()
    out[:, hip] = quat.mul(quat.inv(grot[:, parents[hip]]), g_hip)
    out[:, knee] = quat.mul(quat.inv(g_hip), g_knee)
    out[:, ankle] = quat.mul(quat.inv(g_knee), grot[:, ankle])
    return out


def cleanup_feet(motion: Motion, reference: Motion | None = None, blend: int = 4, spec: CanonicalSpec = CANONICAL,
                 floor: torch.Tensor | None = None) -> Motion:
    """Pin the feet of a canonical ``motion`` during the contacts of ``reference`` (default: itself); ``floor``:
    see :func:`motioncore.representation.foot_contacts`."""
    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("cleanup_feet: expected a motion on the canonical skeleton")
    ref = reference if reference is not None else motion
    if ref.num_frames != motion.num_frames:
        raise ValueError(f"cleanup_feet: expected a reference of {motion.num_frames} frames, got {ref.num_frames}")
    ref_gpos = ref.global_positions()
    contacts = foot_contacts(ref_gpos, ref.fps, spec, floor)  # (T, 4): Foot_L, Toes_L, Foot_R, Toes_R
    rest = rest_positions(spec.skeleton.offsets, spec.skeleton.parents)
    feet = list(spec.feet)
    ankle_floor = float(rest[feet[0], 1] - rest[feet, 1].min())
    toe_floor = min(0.0, float(ref_gpos[:, [feet[1], feet[3]], 1].min()))  # a content's lower floor holds
    lrot = motion.lrot
    for side, (hip, knee, ankle) in enumerate(spec.legs):
        grot, gpos = fk(lrot, motion.lpos, spec.skeleton.parents)
        target = ankle_targets(gpos[:, ankle], contacts[:, 2 * side] > 0.5, blend, ankle_floor)
        # the foot keeps its orientation, so its toes keep their height above the ankle: lift the ankle where they
        # would go through the floor
        toes_y = target[:, 1] + gpos[:, feet[2 * side + 1], 1] - gpos[:, ankle, 1]
        target[:, 1] += (toe_floor - toes_y).clamp_min(0.0)
        lrot = two_bone_ik(grot, gpos, lrot, spec.skeleton.parents, hip, knee, ankle, target)
    return Motion(motion.skeleton, lrot, motion.lpos, motion.fps)
