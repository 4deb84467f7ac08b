"""Compare style-learning settings: content kept vs style gained, read by the evaluation classifiers.

    python benchmarks/style_variants.py --example demo_out/pose/elderly.bvh --style elderly \\
        --content LIBRARY_DIR --variants '{"paper": {"lambda_p": 0}, "pp0.2": {}}'

For each variant (overrides of the style's configs, :func:`transfer.style_config.split_config`), learns the style from ``--example`` with the dataset
cache's train split as content motions, applies it (K from the config, no neutralisation) to
every Bandai-2 BVH in ``--content`` (named ``dataset-2_<content>_<style>_<n>.bvh``), and prints
the content classifier's accuracy against the file's content, the style classifier's accuracy
against ``--style`` and its mean probability for it.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--example", type=Path, required=True, help="style example (.bvh or video)")
    ap.add_argument("--style", required=True, help="style words; also the style classifier's target label")
    ap.add_argument("--content", type=Path, required=True, help="folder of Bandai-2 BVH clips")
    ap.add_argument("--text", default="walk", help="content of the example (default: %(default)s)")
    ap.add_argument("--variants", default='{"default": {}}', help="JSON: name -> config overrides")
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[1] / "cache" / "dataset")
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from evaluation.classifiers import default_weights, load_classifier
    from mlcore.dataset import MotionDataset
    from motioncore.representation import encode
    from transfer.apply import apply_style_features
    from transfer.bundle import load_models
    from transfer.learn import learn_style
    from transfer.style_config import split_config
    from transfer.style_file import style_model
    from video2style.pipeline import read_clip

    m = load_models()
    data = MotionDataset(args.data, "train")
    content_clf, style_clf = load_classifier(default_weights("content")), load_classifier(default_weights("style"))
    example = m.normalize(encode(read_clip(args.example, progress=None).canonical))
    clips = sorted(args.content.glob("dataset-2_*.bvh"))
    if not clips:
        raise SystemExit(f"{args.content}: no dataset-2_*.bvh clips")
    contents = [c.stem.split("_")[1] for c in clips]
    xs = [m.normalize(encode(read_clip(c).canonical)) for c in clips]
    target = style_clf.config.classes.index(args.style)
    for name, overrides in json.loads(args.variants).items():
        learned, config = split_config(overrides)
        t0 = time.time()
        style, info = learn_style(m, data, example, args.style, args.text, learned, apply=config)
        model = style_model(m.prior, style)
        raw = [m.denormalize(apply_style_features(m, model, x, learned, config)) for x in xs]
        with torch.no_grad():
            pred = [content_clf.config.classes[int(content_clf(content_clf.standardize(r)[None]).argmax())] for r in raw]
            probs = [torch.softmax(style_clf(style_clf.standardize(r)[None]), -1)[0] for r in raw]
        cra = sum(p == c for p, c in zip(pred, contents)) / len(clips)
        sra = sum(int(p.argmax()) == target for p in probs) / len(clips)
        mean_p = sum(float(p[target]) for p in probs) / len(clips)
        hist = info["history"]
        print(f"{name:12s} {len(hist)} it, L_rec {hist[0][0]:.3f}->{hist[-1][0]:.3f}, L_s {hist[-1][1]:.3f} | content acc {cra:.2f} "
              f"style acc {sra:.2f} P({args.style}) {mean_p:.2f} | read as {pred} | {time.time() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
