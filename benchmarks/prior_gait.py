"""How the shipped prior's text-to-motion walks step, against real walks: foot skating and ankle lift.

    python benchmarks/prior_gait.py [--seeds 8] [--steps 50] [--guidance 2.0] [--contact-rate 0.02]
        [--contact-iterations 2] [--no-derive-positions] [--frames 80] [--data-length] [--dataset] [--prior W] [REAL.bvh ...]

For each caption and seed, one 80-frame sample of the prior (as ``video2style.pipeline.prior_samples``: by
default the project's ``transfer.sampling.TextToMotion`` settings; ``--contact-rate 0``, the draw without the
planted-feet guide) is measured twice: decoded from its rotation channels (``representation.decode``,
what the pipeline uses) and from its position channels (``representation.decode_positions``; the project's settings
derive those from the rotation channels, so the two agree: ``--no-derive-positions`` shows the model's own); the BVH
files given (e.g. ../shared/data/xia_test/neutral_*.bvh) are measured the same way, and with ``--dataset`` the prior's own training data: the first 12 neutral
("normal" style, unmirrored) training clips of each of those actions in the dataset cache. Columns: the foot-skating ratio of ``evaluation.metrics`` (frames where a foot
is within 3 cm of its lowest point and moves faster than 0.5 m/s) and the ankle lift (the smaller of the
two ankles' highest minus lowest point over the clip). Real walking lifts the ankle 15-25 cm. ``--frames`` sets
the samples' length; with ``--data-length`` each caption's is that of the data's clips of its action (at most
``--frames``; ``transfer.content_bank.DATA_FRAMES``): a run, 46-67 frames in the data, is then not drawn longer than
any run the prior learned from.
"""
from __future__ import annotations

import argparse
import functools
import statistics
from pathlib import Path

CAPTIONS = ("a person walks", "a person runs", "a person walks and turns left")
ACTIONS = ("walk", "run", "walk-turn-left")  # the same actions' labels in the dataset cache


def gait(motion=None, gpos=None, fps: float = 20.0) -> tuple[float, float]:
    """``(skating ratio, ankle lift in metres)`` of a canonical motion, or of global positions ``(T, J, 3)``."""
    from motioncore.skating import foot_skating_ratio
    from motioncore.skeleton import CANONICAL

    if motion is not None:
        gpos, fps = motion.global_positions(), motion.fps
    ankles = (CANONICAL.feet[0], CANONICAL.feet[2])
    lift = min(float(gpos[:, j, 1].max() - gpos[:, j, 1].min()) for j in ankles)
    return foot_skating_ratio(gpos, fps), lift


@functools.cache
def _training_data():
    """The dataset cache's train split (read once)."""
    from mlcore.dataset import MotionDataset
    from video2style.paths import default_dataset_dir

    return MotionDataset(default_dataset_dir(), "train")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("real", nargs="*", type=Path, help="BVH files of real walks to compare with")
    ap.add_argument("--seeds", type=int, default=8)
    from transfer.sampling import TextToMotion

    TextToMotion.add_options(ap)
    ap.add_argument("--dataset", action="store_true", help="also the training clips of the dataset cache")
    ap.add_argument("--frames", type=int, default=80, help="sample length (default: 80, the prior's training window)")
    ap.add_argument("--data-length", action="store_true", help="sample each caption as long as its neutral training "
                    "clips are (median, transfer.content_bank.DATA_FRAMES; at most --frames): runs are 46-67 frames in the data")
    ap.add_argument("--prior", type=Path, help="a prior's weights to measure instead of the shipped one "
                    "(e.g. a training run's denoiser.safetensors)")
    args = ap.parse_args()
    import torch

    from mlcore.shipped import weights_path
    from motioncore.representation import decode, decode_positions
    from motioncore.retarget import place_on_floor
    from transfer.bundle import ENCODER_FILE, MethodBundle, load_models
    from transfer.content_bank import DATA_FRAMES
    from video2style.pipeline import read_clip

    m = MethodBundle.from_pretrained((args.prior, weights_path(ENCODER_FILE))) if args.prior else load_models()
    settings = TextToMotion.from_options(args)
    print(f"prior: {m.prior_path}; {settings}")
    text = m.text_encoder.encode(list(CAPTIONS))
    lengths = dict.fromkeys(CAPTIONS, args.frames)
    if args.data_length:
        lengths = {c: min(args.frames, DATA_FRAMES[a]) for c, a in zip(CAPTIONS, ACTIONS)}
        print("sample lengths: " + ", ".join(f"{c!r} {n} frames" for c, n in lengths.items()))
    rows: dict[str, list[tuple[float, float]]] = {}
    for seed in range(args.seeds):
        for length in sorted(set(lengths.values()), reverse=True):  # one batch when all are as long
            group = [i for i, c in enumerate(CAPTIONS) if lengths[c] == length]
            x = m.text_to_motion(text[group], length, torch.Generator().manual_seed(seed), settings)
            for i, feats in zip(group, m.denormalize(x)):
                rows.setdefault(f"prior: {CAPTIONS[i]}", []).append(gait(decode(feats)))
                rows.setdefault(f"  position channels: {CAPTIONS[i]}", []).append(
                    gait(gpos=decode_positions(feats.double()).float()))
    if args.dataset:
        data = _training_data()
        for action in ACTIONS:
            picked = [i for i, r in enumerate(data.records) if r.content == action and r.style == "normal"
                      and not r.mirrored][:12]
            feats = [data.clip(i, normalized=False) for i in picked]
            rows[f"training data: {action}"] = [gait(place_on_floor(decode(f))) for f in feats]
            rows[f"  position channels: {action}"] = [gait(gpos=decode_positions(f.double()).float()) for f in feats]
    print(f"{'clip':44s} {'skating %':>18s} {'ankle lift cm':>18s}")
    for caption, values in rows.items():
        skate, lift = [100 * v[0] for v in values], [100 * v[1] for v in values]
        print(f"{caption[:44]:44s} {statistics.median(skate):6.1f} ({min(skate):4.1f}-{max(skate):5.1f})"
              f" {statistics.median(lift):6.1f} ({min(lift):4.1f}-{max(lift):4.1f})   median (range) of {len(values)}")
    for path in args.real:
        skate, lift = gait(read_clip(path).canonical)
        print(f"{path.name:44s} {100 * skate:6.1f} {'':11s} {100 * lift:6.1f}")


if __name__ == "__main__":
    main()
