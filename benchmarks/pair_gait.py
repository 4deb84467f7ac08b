"""The neutral pair of examples longer than the prior's window: drawn whole against drawn in windows.

    python -m benchmarks.pair_gait [--split val] [--per-style 3] [--styles normal elderly ...]

For the first ``--per-style`` walk clips of each style in a split of the dataset cache (130-272 frames at 20 fps;
the prior trained on 80-frame windows), the neutral pair that learning draws (:func:`transfer.learn.neutral_pair`,
the default config, caption "a person walks", the bound to neutral clips off so that only the drawing differs) is
made twice: whole (``pair_windowed`` off, as before 2026-12-06) and in 80-frame windows crossfaded over 20 (the
default). Printed per clip and as medians: the foot-skating ratio and the ankle lift (:func:`benchmarks.prior_gait.gait`)
of the example and of both pairs. A neutral walk's pair should step as the walk does.
"""
from __future__ import annotations

import argparse
import statistics
from dataclasses import replace

STYLES = ("normal", "elderly", "exhausted", "feminine", "active")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--split", default="val", choices=("train", "val", "test"))
    ap.add_argument("--per-style", type=int, default=3)
    ap.add_argument("--styles", nargs="+", default=list(STYLES))
    args = ap.parse_args()

    from benchmarks.prior_gait import gait
    from mlcore.dataset import MotionDataset
    from motioncore.representation import decode
    from motioncore.retarget import place_on_floor
    from transfer.bundle import load_models
    from transfer.learn import neutral_pair
    from transfer.style_config import LearnConfig
    from video2style.paths import default_dataset_dir

    m = load_models()
    data = MotionDataset(default_dataset_dir(), args.split)
    config = LearnConfig(pair_between=False)
    kinds = {"example": None, "whole": replace(config, pair_windowed=False), "windows": config}
    rows: dict[str, list[tuple[float, float]]] = {k: [] for k in kinds}
    print(f"{'clip':44s} {'frames':>6s}  " + "  ".join(f"{k + ' skate % / lift cm':>28s}" for k in kinds))
    for style in args.styles:
        picked = [i for i, r in enumerate(data.records) if r.content == "walk" and r.style == style and not r.mirrored]
        for i in picked[: args.per_style]:
            x = data.clip(i)
            for kind, cfg in kinds.items():
                f = x if cfg is None else neutral_pair(m, x, cfg, "a person walks")
                skate, lift = gait(place_on_floor(decode(m.denormalize(f))))
                rows[kind].append((100 * skate, 100 * lift))
            print(f"{data.records[i].name[:44]:44s} {x.shape[0]:6d}  "
                  + "  ".join(f"{v[-1][0]:19.1f} / {v[-1][1]:5.1f}" for v in rows.values()))
    print(f"{'median':44s} {'':6s}  " + "  ".join(
        f"{statistics.median(a for a, _ in v):19.1f} / {statistics.median(b for _, b in v):5.1f}" for v in rows.values()))


if __name__ == "__main__":
    main()
