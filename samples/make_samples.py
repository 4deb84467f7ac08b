"""Regenerate the project-made sample clips in this folder (no external data).

    python samples/make_samples.py
"""
from __future__ import annotations

import math
from pathlib import Path

import torch

from motioncore import quat
from motioncore.bvh import BvhLayout, write_bvh
from motioncore.motion import Motion
from motioncore.retarget import place_on_floor
from motioncore.skeleton import CANONICAL

HERE = Path(__file__).resolve().parent


def procedural_walk(seconds: float = 6.0, fps: float = 30.0, speed: float = 1.3, cadence: float = 0.95, turn: float = 0.0) -> Motion:
    """A simple sinusoidal walk cycle on the canonical skeleton (cadence: strides per second)."""
    sk = CANONICAL.skeleton
    n = int(seconds * fps)
    t = torch.arange(n, dtype=torch.float32) / fps
    ph = 2 * math.pi * cadence * t
    euler = torch.zeros(n, sk.num_joints, 3)  # (x, y, z) angles, applied as ZXY below
    ix = sk.index
    for side, sign in (("L", 1.0), ("R", -1.0)):
        s = torch.sin(ph + (0 if side == "L" else math.pi))
        c = torch.cos(ph + (0 if side == "L" else math.pi))
        euler[:, ix(f"UpperLeg_{side}"), 0] = -0.45 * s  # flexion (x axis; negative swings the leg forward)
        euler[:, ix(f"LowerLeg_{side}"), 0] = 0.6 * torch.clamp(c, min=0) + 0.05
        euler[:, ix(f"Foot_{side}"), 0] = -0.2 * s
        euler[:, ix(f"UpperArm_{side}"), 2] = -sign * 1.25  # arms down from the T-pose
        euler[:, ix(f"UpperArm_{side}"), 0] = 0.35 * s
        euler[:, ix(f"LowerArm_{side}"), 1] = sign * (0.3 + 0.15 * (1 + s))
    euler[:, ix("Spine"), 1] = 0.08 * torch.sin(ph)
    euler[:, ix("Chest"), 1] = -0.12 * torch.sin(ph)
    lrot = quat.from_euler(euler[..., [2, 0, 1]], "ZXY")
    heading = turn * t
    lrot[:, 0] = quat.mul(quat.from_yaw(heading), lrot[:, 0])
    step = torch.stack([torch.sin(heading), torch.zeros(n), torch.cos(heading)], -1) * speed / fps
    root = torch.cumsum(step, 0)
    root[:, 1] = 0.92 + 0.02 * torch.cos(2 * ph)
    lpos = sk.offsets.expand(n, -1, -1).clone()
    lpos[:, 0] = root
    return place_on_floor(Motion(sk, lrot, lpos, fps))


def main() -> None:
    layout = BvhLayout.default(CANONICAL.skeleton, "ZXY", scale=0.01)  # centimetres, like most tools
    write_bvh(HERE / "walk_procedural.bvh", procedural_walk(), layout)
    write_bvh(HERE / "walk_turn_procedural.bvh", procedural_walk(turn=0.35), layout)
    print("wrote", ", ".join(p.name for p in sorted(HERE.glob("*.bvh"))))


if __name__ == "__main__":
    main()
