"""Quality of the shipped prior and motion encoder on the Bandai-2 test split (issue 4's evidence).

    python benchmarks/eval_prior.py [--data cache/dataset] [--previews prior_previews/] [--threads 2] [--prior W] [--encoder W]

Prints retrieval R@1/R@3 (motion -> text over content captions and over content x style captions,
text -> motion in galleries of 32), then samples one clip per content x style caption and prints
the Fréchet distance to the real test originals on the motion encoder's features and on the
evaluation content classifier's features, the foot-skating ratio of samples and of real clips,
and seconds per sample. ``--previews`` writes one mp4 per content with its seven styles side by side.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[1] / "cache" / "dataset")
    ap.add_argument("--split", default="test")
    ap.add_argument("--previews", type=Path)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--prior", type=Path, help="a prior's weights to measure instead of the shipped one")
    ap.add_argument("--encoder", type=Path, help="a motion encoder's weights instead of the shipped one")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from evaluation.classifiers import default_weights, load_classifier
    from evaluation.prior_eval import retrieval, sample_quality
    from transfer.bundle import ENCODER_FILE, PRIOR_FILE, MethodBundle, load_models
    from transfer.dataset import MotionDataset
    from transfer.shipped import weights_path

    if not (args.data / "features.safetensors").is_file():
        raise SystemExit(f"{args.data}: no dataset cache (video2style dataset ...)")
    m = load_models() if not (args.prior or args.encoder) else \
        MethodBundle.from_pretrained((args.prior or weights_path(PRIOR_FILE), args.encoder or weights_path(ENCODER_FILE)))
    print(f"prior: {m.prior_path}")
    data = MotionDataset(args.data, args.split)
    ret = retrieval(m.motion_encoder, m.text_encoder, data)
    for k, v in ret.items():
        print(f"{k:22s} {v if k == 'clips' else f'{100 * v:.1f} %'}")
    q = sample_quality(m, data, args.previews, steps=args.steps, classifier=load_classifier(default_weights("content")))
    for k, v in q.items():
        print(f"{k:22s} {v:.4f}" if isinstance(v, float) else f"{k:22s} {v}")
    if args.json:
        args.json.write_text(json.dumps({"retrieval": ret, "samples": q}, indent=1))


if __name__ == "__main__":
    main()
