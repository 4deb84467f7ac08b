"""Automatic humanoid mapping: the generated rig corpus and any folders of real BVH files.

    python benchmarks/humanoid_mapping.py [FOLDER ...]

For each convention in tests/rig_corpus.py: whether every role was found exactly, and the
canonical -> rig -> BVH text (its units, channels, Euler orders) -> canonical round-trip error.
For each real file: how long the mapping took and, where the file names its joints after the
canonical roles (Bandai), whether the roles found are those names.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import torch

from motioncore import quat
from motioncore.bvh import format_bvh, parse_bvh, read_bvh
from motioncore.retarget import RetargetError, from_canonical, make_rig, to_canonical
from motioncore.skeleton import CANONICAL

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the corpus lives with the tests
from tests.helpers import random_motion
from tests.rig_corpus import CASES, DISPUTED_CASES


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


def folder(path: Path) -> None:
    files = sorted(path.rglob("*.bvh"))
    named = mismatched = failed = 0
    seconds = []
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
        if set(CANONICAL.skeleton.names) <= set(motion.skeleton.names):
            named += 1
            roles = rig.humanoid.names(motion.skeleton)
            if any(roles[r] != r for r in CANONICAL.skeleton.names):
                mismatched += 1
                print(f"  {f.name}: {({r: n for r, n in roles.items() if n != r})}")
    med = sorted(seconds)[len(seconds) // 2] if seconds else 0.0
    print(f"{path}: {len(files)} files, {failed} not mapped, {named} with role-named joints of which "
          f"{mismatched} mapped differently; median {med * 1000:.0f} ms per file")


if __name__ == "__main__":
    torch.set_num_threads(1)
    corpus()
    for a in sys.argv[1:]:
        folder(Path(a))
