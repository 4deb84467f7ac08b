"""How the shipped prior's text-to-motion walks step, against real walks: foot skating and ankle lift.

    python benchmarks/prior_gait.py [--seeds 8] [--dataset] [REAL.bvh ...]

For each caption and seed, one 80-frame sample of the prior (``video2style.pipeline.prior_samples``, 50
DDIM steps, guidance 2.5) is measured; the BVH files given (e.g. ../shared/data/xia_test/neutral_*.bvh)
are measured the same way, and with ``--dataset`` the prior's own training data: the first 12 neutral
("normal" style, unmirrored) training clips of each of those actions in the dataset cache. Columns: the foot-skating ratio of ``evaluation.metrics`` (frames where a foot
is within 3 cm of its lowest point and moves faster than 0.5 m/s) and the ankle lift (the smaller of the
two ankles' highest minus lowest point over the clip). Real walking lifts the ankle 15-25 cm.
"""
from __future__ import annotations

import argparse
import statistics
from pathlib import Path

CAPTIONS = ("a person walks", "a person runs", "a person walks and turns left")
ACTIONS = ("walk", "run", "walk-turn-left")  # the same actions' labels in the dataset cache


def gait(motion) -> tuple[float, float]:
    """``(skating ratio, ankle lift in metres)`` of a canonical motion."""
    from evaluation.metrics import foot_skating_ratio
    from motioncore.skeleton import CANONICAL

    gpos = motion.global_positions()
    ankles = (CANONICAL.feet[0], CANONICAL.feet[2])
    lift = min(float(gpos[:, j, 1].max() - gpos[:, j, 1].min()) for j in ankles)
    return foot_skating_ratio(gpos, motion.fps), lift


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("real", nargs="*", type=Path, help="BVH files of real walks to compare with")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--dataset", action="store_true", help="also the training clips of the dataset cache")
    args = ap.parse_args()
    from video2style.pipeline import place_on_floor, prior_samples, read_clip

    rows: dict[str, list[tuple[float, float]]] = {c: [] for c in CAPTIONS}
    for seed in range(args.seeds):
        for caption, motion in zip(CAPTIONS, prior_samples(list(CAPTIONS), seed=seed)):
            rows[caption].append(gait(motion))
    if args.dataset:
        from motioncore.representation import decode
        from transfer.dataset import MotionDataset
        from video2style.paths import default_dataset_dir

        data = MotionDataset(default_dataset_dir(), "train")
        for action in ACTIONS:
            picked = [i for i, r in enumerate(data.records) if r.content == action and r.style == "normal"
                      and not r.mirrored][:12]
            rows[f"training data: {action}"] = [gait(place_on_floor(decode(data.clip(i, normalized=False))))
                                                for i in picked]
    print(f"{'clip':36s} {'skating %':>18s} {'ankle lift cm':>18s}")
    for caption, values in rows.items():
        skate, lift = [100 * v[0] for v in values], [100 * v[1] for v in values]
        name = caption if caption.startswith("training") else f"prior: {caption}"
        print(f"{name:36s} {statistics.median(skate):6.1f} ({min(skate):4.1f}-{max(skate):5.1f})"
              f" {statistics.median(lift):6.1f} ({min(lift):4.1f}-{max(lift):4.1f})   median (range) of {len(values)}")
    for path in args.real:
        skate, lift = gait(read_clip(path).canonical)
        print(f"{path.name:36s} {100 * skate:6.1f} {'':11s} {100 * lift:6.1f}")


if __name__ == "__main__":
    main()
