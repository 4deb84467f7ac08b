"""``video2style train-classifier``: train or resume an evaluation classifier (:func:`evaluation.classifiers.train_classifier`)."""
from __future__ import annotations

from pathlib import Path

from video2style.arguments import add_device, positive, style_option
from video2style.commands.checks import data_inputs
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``train-classifier`` command's parser, on the subparsers ``sub``."""
    from video2style.paths import cache_dir, default_dataset_dir

    tc = sub.add_parser("train-classifier", help="train (or resume) an ST-GCN content or style classifier for evaluate")
    tc.add_argument("--target", choices=["content", "style"], required=True, help="what the classifier recognises")
    tc.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    tc.add_argument("--out", type=Path, help="run folder (default: <cache>/runs/classifier_<target>)")
    tc.add_argument("--weights", type=Path, help="exported weights (default: classifier_<target>.safetensors in the run "
                    "folder; name the package's mlcore/weights/ file to replace the shipped ones)")
    tc.add_argument("--max-minutes", type=positive, default=10.0, help="stop after this long; run again to resume (default: %(default)s)")
    tc.add_argument("--max-steps", type=int, default=600, help="stop at this many optimiser steps in all (default: %(default)s)")
    tc.add_argument("--threads", type=int, default=0, help="torch threads, 0 = torch's default (default: %(default)s)")
    add_device(tc)
    tc.add_argument("--seed", type=style_option("seed"), default=None, help="random seed (default: the config's)")
    tc.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    tc.set_defaults(func=run, run_root=cache_dir() / "runs")


def run(args) -> None:
    import torch

    from evaluation.classifiers import (
        ClassifierTrainConfig,
        default_weights,
        train_classifier,
    )

    if args.threads:
        torch.set_num_threads(args.threads)
    explicit = {"seed": args.seed} if args.seed is not None else {}
    out = args.out or args.run_root / f"classifier_{args.target}"
    weights = args.weights or out / default_weights(args.target).name  # the shipped file only when named
    check_outputs([("--out", out), ("--out", out / "checkpoint.safetensors"), ("--out", out / "log.csv"),
                   ("--weights", weights), ("--weights", weights.with_suffix(".json"))], data_inputs(args.data))
    card = train_classifier(args.data, out, args.target, args.max_minutes, args.max_steps,
                            ClassifierTrainConfig(target=args.target, **explicit), weights, explicit, progress=not args.quiet,
                            device=args.device)
    print(f"{args.target} classifier: step {card['steps']}, test accuracy {100 * card['test_accuracy']:.1f}% "
          f"on {card['test_clips']} clips; weights: {weights}")
