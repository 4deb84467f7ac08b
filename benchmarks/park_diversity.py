"""Diversity of Park et al.'s stylizer: outputs from different noise, measured and shown.

    python benchmarks/park_diversity.py [--data cache/dataset] [--grid park_grid/] [--weights W]

For 10 Bandai-2 test originals (one per content) x 7 domains x 4 noise seeds, prints the mean
pairwise distance between the 4 outputs of each (clip, domain): L1 in normalised features and
the mean per-joint distance of the decoded positions. ``--grid`` writes, for three clips, an mp4
of the content beside its four elderly-domain variants (and a png of the middle frame).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[1] / "cache" / "dataset")
    ap.add_argument("--weights", type=Path)
    ap.add_argument("--grid", type=Path)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from mlcore.captions import BANDAI2_CONTENTS
    from mlcore.dataset import MotionDataset
    from motioncore.render import Panel, render_video
    from motioncore.representation import decode
    from motioncore.skeleton import CANONICAL
    from park.infer import pairwise_diversity, stylize_noise
    from video2style.park_apply import park_model

    model = park_model(args.weights)
    data = MotionDataset(args.data, "test")
    clips = []
    for c in BANDAI2_CONTENTS:
        clips.append(next(i for i, r in enumerate(data.records) if r.content == c and r.dataset == "bandai2" and not r.mirrored))
    feat, pos = [], []
    for i in clips:
        x = data.clip(i)
        for d in model.config.domains:
            d_out = pairwise_diversity(stylize_noise(model, x, d, seed=0, n_variants=args.seeds), data.mean, data.std)
            feat.append(d_out["feature_l1"])
            pos.append(d_out["position_m"])
    print(f"{len(clips)} clips x {len(model.config.domains)} domains x {args.seeds} seeds: "
          f"mean pairwise L1 {sum(feat) / len(feat):.3f} (normalised features), {sum(pos) / len(pos):.3f} m per joint")
    if args.grid:
        import cv2

        sk = CANONICAL.skeleton
        for i in clips[:3:]:
            x = data.clip(i)
            outs = stylize_noise(model, x, "elderly", seed=0, n_variants=4)
            panels = [Panel(decode(x * data.std + data.mean).global_positions(), sk.parents, f"content: {data.records[i].name[10:]}", names=sk.names)]
            panels += [Panel(decode(o * data.std + data.mean).global_positions(), sk.parents, f"elderly, seed {k}", names=sk.names)
                       for k, o in enumerate(outs)]
            out = render_video(panels, args.grid / f"{data.records[i].content}.mp4", CANONICAL.fps, size=(260, 260), progress=False)
            cap = cv2.VideoCapture(str(out))
            cap.set(cv2.CAP_PROP_POS_FRAMES, int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) // 2)
            ok, frame = cap.read()
            if ok:
                cv2.imwrite(str(out.with_suffix(".png")), frame)
            print(f"wrote {out}")


if __name__ == "__main__":
    main()
