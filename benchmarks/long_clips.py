"""Time and peak memory of ``apply`` and ``preview`` against clip length.

    python -m benchmarks.long_clips STYLE.v2s [--frames 1000 10000 100000 200000] [--fps 30] [--out /tmp/long]   # from the repository root

Writes a 30 fps (``--fps``) BVH of each length on a CMU-like skeleton (a walk-like synthetic motion), then runs
``video2style apply STYLE CLIP -o OUT`` and ``video2style preview CLIP -o OUT.mp4`` each in its own
process and prints wall time and peak resident memory (the child's ru_maxrss).
"""
from __future__ import annotations

import argparse
import math
import os
import subprocess
import time
from pathlib import Path

import torch

from motioncore import quat
from motioncore.bvh import BvhLayout, write_bvh
from motioncore.motion import Motion
from motioncore.retarget import from_canonical, make_rig
from testkit.motions import cmu_like_skeleton
from testkit.rig_corpus import case


def long_walk(frames: int, fps: float = 30.0) -> Motion:
    """A canonical walk-ish motion of ``frames`` frames: periodic limb swings, a slowly turning path."""
    from motioncore.skeleton import CANONICAL

    sk = CANONICAL.skeleton
    t = torch.arange(frames, dtype=torch.float32) / fps
    phase = 2 * math.pi * 0.9 * t
    angles = torch.zeros(frames, sk.num_joints, 3)
    for name, amp, sign in (("UpperLeg_L", 0.5, 1), ("UpperLeg_R", 0.5, -1), ("UpperArm_L", 0.4, -1), ("UpperArm_R", 0.4, 1)):
        angles[:, sk.index(name), 0] = sign * amp * torch.sin(phase)
    for name in ("LowerLeg_L", "LowerLeg_R"):
        angles[:, sk.index(name), 0] = 0.4 + 0.4 * torch.sin(phase + (0 if name.endswith("L") else math.pi))
    for name, z in (("UpperArm_L", -1.2), ("UpperArm_R", 1.2)):
        angles[:, sk.index(name), 2] = z
    lrot = quat.from_euler(angles, "ZXY")
    heading = 0.05 * t
    lrot[:, 0] = quat.mul(quat.from_yaw(heading), lrot[:, 0])
    lpos = sk.offsets.expand(frames, -1, -1).clone()
    step = 1.2 / fps
    lpos[:, 0, 0] = torch.cumsum(step * torch.sin(heading), 0)
    lpos[:, 0, 1] = 0.9 + 0.02 * torch.sin(2 * phase)
    lpos[:, 0, 2] = torch.cumsum(step * torch.cos(heading), 0)
    return Motion(sk, lrot, lpos, fps)


def run(cmd: list[str]) -> tuple[float, float, int]:
    """(seconds, peak MiB of the child, exit status)."""
    t0 = time.time()
    child = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(child.pid, 0)
    return time.time() - t0, usage.ru_maxrss / 1024, os.waitstatus_to_exitcode(status)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("style", type=Path)
    ap.add_argument("--frames", type=int, nargs="+", default=[1000, 10000, 100000, 200000])
    ap.add_argument("--fps", type=float, default=30.0, help="the takes' frame rate (1: a 5-hour take is 18,000 frames; "
                    "apply resamples to 20 fps first)")
    ap.add_argument("--out", type=Path, default=Path("/tmp/long_clips"))
    ap.add_argument("--rig", default="mixamo", help="rig convention from testkit/rig_corpus.py (default: %(default)s)")
    ap.add_argument("--no-preview", action="store_true")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    c = case(args.rig) if args.rig != "cmu_like" else None
    sk = c.skeleton if c else cmu_like_skeleton()
    layout = c.layout if c else BvhLayout.default(sk)
    rig = make_rig(sk)
    print(f"rig {args.rig} ({sk.num_joints} joints), {args.fps:g} fps; peak memory: each command's own (wait4 ru_maxrss)")
    print(f"{'frames':>8s} {'minutes':>8s} {'apply s':>8s} {'apply MiB':>9s} {'preview s':>9s} {'preview MiB':>11s}")
    for n in args.frames:
        clip = args.out / f"walk_{n}_{args.fps:g}fps.bvh"
        write_bvh(clip, from_canonical(long_walk(n, args.fps), rig), layout)
        sa, ma, rca = run(["video2style", "apply", str(args.style), str(clip), "-o", str(args.out / "out"), "--no-preview"])
        row = f"{n:8d} {n / args.fps / 60:8.1f} {sa:8.1f} {ma:9.0f}" + ("" if rca == 0 else f" (exit {rca})")
        if not args.no_preview:
            sp, mp, rcp = run(["video2style", "preview", str(clip), "-o", str(args.out / f"{clip.stem}.mp4")])
            row += f" {sp:9.1f} {mp:11.0f}" + ("" if rcp == 0 else f" (exit {rcp})")
        print(row, flush=True)


if __name__ == "__main__":
    main()
