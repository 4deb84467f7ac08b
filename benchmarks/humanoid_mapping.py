"""Automatic humanoid mapping: the generated rig corpus and any folders of real BVH files.

    python -m benchmarks.humanoid_mapping [--posed N] [FOLDER ...]   # from the repository root (the corpus lives with the tests)

For each convention in testkit/rig_corpus.py: whether every role was found exactly, and the
canonical -> rig -> BVH text (its units, channels, Euler orders) -> canonical round-trip error.
For each convention and each pose of testkit/rig_poses.py, on a rest pose laid along X (Bandai's) so
that the frames decide: whether every role was found exactly. For each real file: how long the
mapping took, what decided it (rest pose, frames, joint names), the up axis, and, where the file
names its joints after the canonical roles (Bandai), whether the roles found are those names.
"""
from __future__ import annotations

import sys
import time
from collections import Counter
from pathlib import Path

import torch

from motioncore import quat
from motioncore.bvh import format_bvh, parse_bvh, read_bvh
from motioncore.humanoid import NotHumanoidError, find_humanoid
from motioncore.kinematics import fk
from motioncore.motion import Motion
from motioncore.retarget import RetargetError, from_canonical, make_rig, to_canonical
from motioncore.skeleton import CANONICAL, Skeleton
from testkit.motions import random_motion
from testkit.rig_corpus import CASES, DISPUTED_CASES
from testkit.rig_poses import POSES, posed_motion


def corpus() -> None:
    print(f"{'case':18s} {'up':>3s} {'rest':>4s} {'units':>5s} {'joints':>6s} {'roles exact':>11s} {'round trip mm':>13s}")
    worst = 0.0
    for c in CASES + DISPUTED_CASES:
        rig = make_rig(c.skeleton)
        exact = rig.humanoid.names(c.skeleton) == c.expected
        m = random_motion(seconds=4.0, seed=7, amplitude=0.4)
        m.lrot[:, [r for r, s in enumerate(rig.mapping) if s is None]] = quat.identity()
        parsed, _ = parse_bvh(format_bvh(from_canonical(m, rig), c.layout), c.name, units=c.layout.scale)
        back = to_canonical(parsed, make_rig(parsed.skeleton, parsed))
        err = float((back.global_positions() - m.global_positions()).norm(dim=-1).max()) * 1000
        worst = max(worst, err)
        print(f"{c.name:18s} {c.up:>3s} {c.rest:>4s} {c.units:>5s} {c.skeleton.num_joints:6d} {exact!s:>11s} {err:13.4f}")
    print(f"{len(CASES + DISPUTED_CASES)} rigs, worst round trip {worst:.4f} mm")


def poses() -> None:
    """Every convention in every pose, the rest pose laid along X: roles exact?"""
    wrong, total = [], 0
    for c in CASES + DISPUTED_CASES:
        for pose in POSES:
            m = posed_motion(c, pose, "bones_x")
            total += 1
            try:
                rig = make_rig(m.skeleton, m)
                ok = rig.humanoid.names(m.skeleton) == c.expected and rig.humanoid.pose != "joint names"
            except RetargetError as e:
                ok = False
                print(f"  {c.name} {pose}: {e}")
            if not ok:
                wrong.append(f"{c.name}/{pose}")
    print(f"poses: {total - len(wrong)} of {total} clips ({len(CASES + DISPUTED_CASES)} conventions x {len(POSES)} "
          f"poses) mapped exactly by geometry{'; wrong: ' + ', '.join(wrong) if wrong else ''}")


_ARM_POSES = {  # left arm: upper arm and forearm directions in the chest's frame (canonical: left +X, forward +Z)
    "arms folded": {"L": ((0.12, -0.9, 0.42), (-0.9, 0.25, 0.35)), "R": ((0.12, -0.9, 0.42), (-0.9, 0.25, 0.35))},
    "one hand high": {"R": ((0.35, 0.9, 0.25), (0.1, 1.0, 0.0))},
    "hands behind back": {"L": ((0.15, -0.9, -0.4), (-0.75, -0.25, -0.6)), "R": ((0.15, -0.9, -0.4), (-0.75, -0.25, -0.6))},
}


def _hold_arms(m, spec: dict) -> None:
    """Set the canonical motion's arms to ``spec`` (directions in the chest's frame) in every frame, in place."""
    names = CANONICAL.skeleton.names
    grot, _ = fk(m.lrot, m.lpos, CANONICAL.skeleton.parents)
    for side, (upper, fore) in spec.items():
        sign = 1.0 if side == "L" else -1.0
        out = torch.tensor([sign, 0.0, 0.0])
        chest = grot[:, names.index("Chest")]
        g_up = quat.mul(chest, quat.between(out, torch.nn.functional.normalize(torch.tensor(upper) * torch.tensor([sign, 1, 1]), dim=0)))
        g_fore = quat.mul(chest, quat.between(out, torch.nn.functional.normalize(torch.tensor(fore) * torch.tensor([sign, 1, 1]), dim=0)))
        shoulder = grot[:, names.index(f"Shoulder_{side}")]
        m.lrot[:, names.index(f"UpperArm_{side}")] = quat.mul(quat.inv(shoulder), g_up)
        m.lrot[:, names.index(f"LowerArm_{side}")] = quat.mul(quat.inv(g_up), g_fore)
        m.lrot[:, names.index(f"Hand_{side}")] = quat.identity()


def real_posed(path: Path, every: int) -> None:
    """Every ``every``-th Bandai clip with its arms held folded / one hand high / behind the back for the whole
    clip, written back onto the file's own skeleton with the joint names taken away: do the frames still give
    every role? (the clips the issue saw refused, made from the clips we have)"""
    files = sorted(path.rglob("*.bvh"))[::every]
    ok, total, bad = 0, 0, []
    for f in files:
        motion, _ = read_bvh(f)
        if not set(CANONICAL.skeleton.names) <= set(motion.skeleton.names):
            continue  # only files whose joints carry the role names can be checked
        rig = make_rig(motion.skeleton, motion, source=str(f))
        canon = to_canonical(motion, rig)
        sk = motion.skeleton
        anon = Skeleton(tuple(f"j{i}" for i in range(sk.num_joints)), sk.parents, sk.offsets, sk.end_sites)
        for pose, spec in _ARM_POSES.items():
            m = Motion(canon.skeleton, canon.lrot.clone(), canon.lpos.clone(), canon.fps)
            _hold_arms(m, spec)
            back = from_canonical(m, rig)
            total += 1
            try:
                found = find_humanoid(anon, back.lrot, back.lpos)
                exact = all(j == sk.index(r) for r, j in zip(CANONICAL.skeleton.names, found.joints)) and found.up == "+Y"
            except NotHumanoidError as e:
                exact = False
                print(f"  {f.name} {pose}: {e}")
            ok += exact
            if not exact:
                bad.append(f"{f.name}/{pose}")
    if not total:
        return
    print(f"{path}: {ok} of {total} clips ({total // len(_ARM_POSES)} files x {len(_ARM_POSES)} arm poses held the whole clip, "
          f"names taken away) mapped exactly with up +Y{'; wrong: ' + ', '.join(bad[:10]) if bad else ''}")


def folder(path: Path) -> None:
    files = sorted(path.rglob("*.bvh"))
    named = mismatched = failed = 0
    seconds = []
    decided, ups = Counter(), Counter()
    for f in files:
        motion, _ = read_bvh(f)
        t0 = time.perf_counter()
        try:
            rig = make_rig(motion.skeleton, motion, source=str(f))
        except RetargetError as e:
            failed += 1
            print(f"  {e}")
            continue
        seconds.append(time.perf_counter() - t0)
        decided["frames" if rig.humanoid.pose.startswith("frame") else rig.humanoid.pose] += 1
        ups[rig.humanoid.up] += 1
        if set(CANONICAL.skeleton.names) <= set(motion.skeleton.names):
            named += 1
            roles = rig.humanoid.names(motion.skeleton)
            if any(roles[r] != r for r in CANONICAL.skeleton.names):
                mismatched += 1
                print(f"  {f.name}: {({r: n for r, n in roles.items() if n != r})}")
    med = sorted(seconds)[len(seconds) // 2] if seconds else 0.0
    print(f"{path}: {len(files)} files, {failed} not mapped, {named} with role-named joints of which "
          f"{mismatched} mapped differently; median {med * 1000:.0f} ms per file; decided by "
          f"{dict(decided)}; up {dict(ups)}")


if __name__ == "__main__":
    torch.set_num_threads(1)
    args = sys.argv[1:]
    every = 0
    if args[:1] == ["--posed"]:  # --posed N: also every N-th clip of each folder with its arms held (real_posed)
        every, args = int(args[1]), args[2:]
    corpus()
    poses()
    for a in args:
        folder(Path(a))
        if every:
            real_posed(Path(a), every)
