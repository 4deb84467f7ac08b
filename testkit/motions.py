"""Synthetic motions for tests and benchmarks: smooth, seeded, on the canonical skeleton."""
from __future__ import annotations

import math

import torch

from motioncore import quat
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL


def random_motion(seconds: float = 10.0, fps: float = 20.0, seed: int = 0, amplitude: float = 0.5) -> Motion:
    """A walking-ish canonical motion: smooth random joint rotations, a curved root path."""
    g = torch.Generator().manual_seed(seed)
    sk = CANONICAL.skeleton
    t = int(seconds * fps)
    time = torch.arange(t) / fps
    j = sk.num_joints
    freq = 0.3 + torch.rand(j, 3, 3, generator=g) * 1.5
    phase = torch.rand(j, 3, 3, generator=g) * 2 * math.pi
    amp = torch.rand(j, 3, 3, generator=g) * amplitude
    angles = (amp * torch.sin(2 * math.pi * freq * time[:, None, None, None] + phase)).sum(-1)  # (T, J, 3)
    lrot = quat.from_euler(angles, "ZXY")
    heading = 0.4 * torch.sin(2 * math.pi * 0.05 * time) + 0.3 * time / seconds
    lrot[:, 0] = quat.mul(quat.from_yaw(heading), lrot[:, 0])
    speed = 1.2
    dx = speed / fps * torch.sin(heading)
    dz = speed / fps * torch.cos(heading)
    root = torch.stack([torch.cumsum(dx, 0), 0.9 + 0.03 * torch.sin(2 * math.pi * 2 * time), torch.cumsum(dz, 0)], -1)
    lpos = sk.offsets.expand(t, -1, -1).clone()
    lpos[:, 0] = root
    return Motion(sk, lrot, lpos, fps)


def bandai_like_skeleton(seed: int = 0):
    """Canonical joints under a ``joint_Root``, each bone's rest direction twisted at random, centimetres."""
    from motioncore.skeleton import Skeleton

    g = torch.Generator().manual_seed(seed)
    sk = CANONICAL.skeleton
    frames = quat.normalize(torch.randn(sk.num_joints, 4, generator=g))
    offsets = [torch.zeros(3)]
    for i in range(sk.num_joints):
        if i == 0:
            offsets.append(torch.tensor([0.05, 0.9, -4.2]))
        else:  # express the canonical bone in the parent's twisted rest frame
            offsets.append(quat.mul_vec(quat.inv(frames[sk.parents[i]]), sk.offsets[i]) * 1.1)
    names = ("joint_Root",) + sk.names
    parents = (-1,) + tuple(p + 1 for p in sk.parents)
    return Skeleton(names, parents, torch.stack(offsets))


CANONICAL_NAMES_MAP = {n: n for n in CANONICAL.skeleton.names}  # a joint map for skeletons using the canonical names

CMU_LIKE_ROLES = {
    "Hips": "Hips", "Spine": "Spine", "Chest": "Spine1", "Neck": "Neck", "Head": "Head",
    **{f"{c}_{s}": f"{side}{n}" for s, side in (("L", "Left"), ("R", "Right")) for c, n in (
        ("Shoulder", "Shoulder"), ("UpperArm", "Arm"), ("LowerArm", "ForeArm"), ("Hand", "Hand"),
        ("UpperLeg", "UpLeg"), ("LowerLeg", "Leg"), ("Foot", "Foot"), ("Toes", "ToeBase"))},
}  # what the automatic mapping must find in cmu_like_skeleton()


def cmu_like_skeleton():
    """A CMU-style hierarchy (zero-length helper joints, extra spine and finger joints) in a T-pose."""
    from motioncore.skeleton import Skeleton

    rows = [
        ("Hips", None, (0, 0, 0)),
        ("LHipJoint", "Hips", (0, 0, 0)), ("LeftUpLeg", "LHipJoint", (0.09, -0.07, 0.02)),
        ("LeftLeg", "LeftUpLeg", (0.0, -0.42, 0)), ("LeftFoot", "LeftLeg", (0, -0.43, 0)),
        ("LeftToeBase", "LeftFoot", (0, -0.04, 0.12)),
        ("RHipJoint", "Hips", (0, 0, 0)), ("RightUpLeg", "RHipJoint", (-0.09, -0.07, 0.02)),
        ("RightLeg", "RightUpLeg", (0.0, -0.42, 0)), ("RightFoot", "RightLeg", (0, -0.43, 0)),
        ("RightToeBase", "RightFoot", (0, -0.04, 0.12)),
        ("LowerBack", "Hips", (0, 0, 0)), ("Spine", "LowerBack", (0, 0.11, -0.01)),
        ("Spine1", "Spine", (0, 0.11, 0)), ("Neck", "Spine1", (0, 0, 0)), ("Neck1", "Neck", (0, 0.17, 0.01)),
        ("Head", "Neck1", (0, 0.09, -0.01)),
        ("LeftShoulder", "Spine1", (0, 0, 0)), ("LeftArm", "LeftShoulder", (0.18, 0.06, -0.02)),
        ("LeftForeArm", "LeftArm", (0.27, 0, 0)), ("LeftHand", "LeftForeArm", (0.19, 0, 0)),
        ("LeftFingerBase", "LeftHand", (0.0, 0, 0)), ("LeftHandIndex1", "LeftFingerBase", (0.04, 0, 0)),
        ("LThumb", "LeftHand", (0.02, 0, 0.02)),
        ("RightShoulder", "Spine1", (0, 0, 0)), ("RightArm", "RightShoulder", (-0.18, 0.06, -0.02)),
        ("RightForeArm", "RightArm", (-0.27, 0, 0)), ("RightHand", "RightForeArm", (-0.19, 0, 0)),
        ("RightFingerBase", "RightHand", (0.0, 0, 0)), ("RightHandIndex1", "RightFingerBase", (-0.04, 0, 0)),
        ("RThumb", "RightHand", (-0.02, 0, 0.02)),
    ]
    names = tuple(r[0] for r in rows)
    parents = tuple(-1 if r[1] is None else names.index(r[1]) for r in rows)
    ends = {names.index("Head"): torch.tensor([0.0, 0.15, 0.0])}
    return Skeleton(names, parents, torch.tensor([r[2] for r in rows], dtype=torch.float32), ends)
