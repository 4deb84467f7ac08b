"""``video2style train-encoder``: train or resume the motion-text encoder (:func:`transfer.motion_encoder.train_motion_encoder`)."""
from __future__ import annotations

from pathlib import Path

from video2style.arguments import (
    add_device,
    add_exclude_styles,
    explicit_settings,
    finite_positive,
    positive,
    positive_int,
    style_option,
)
from video2style.commands.checks import run_folder_checks


def add_parser(sub) -> None:
    """The ``train-encoder`` command's parser, on the subparsers ``sub``."""
    from video2style.paths import cache_dir, default_dataset_dir

    e = sub.add_parser("train-encoder", help="train (or resume) the motion-text encoder on top of a trained prior")
    e.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    e.add_argument("--prior", type=Path, required=True, help="the prior's denoiser.safetensors")
    e.add_argument("--out", type=Path, default=cache_dir() / "runs" / "encoder", help="run folder (default: %(default)s)")
    e.add_argument("--max-minutes", type=positive, default=30.0, help="stop after this long; run again to resume (default: %(default)s)")
    e.add_argument("--max-steps", type=int, default=10**9, help="stop at this many optimiser steps in all (default: %(default)s)")
    for name, typ in [("batch_size", positive_int), ("window", positive_int), ("lr", finite_positive),
                      ("seed", style_option("seed"))]:
        e.add_argument(f"--{name.replace('_', '-')}", dest=name, type=typ, default=None,
                       help="default: see transfer.motion_encoder.EncoderTrainConfig; a resumed run keeps its own")
    add_exclude_styles(e)
    add_device(e)
    e.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    e.set_defaults(func=run)


def run(args) -> None:
    from transfer.motion_encoder import EncoderTrainConfig, train_motion_encoder

    run_folder_checks(args, ["checkpoint.safetensors", "motion_encoder.safetensors", "motion_encoder.json", "val.csv"],
                       [("the --prior file", args.prior), ("the folder of --prior", args.prior.parent)])
    explicit = explicit_settings(args, EncoderTrainConfig)
    trainer = train_motion_encoder(args.data, args.prior, args.out, EncoderTrainConfig(**explicit), args.max_minutes,
                                   args.max_steps, explicit, progress=not args.quiet, device=args.device)
    print(f"step {trainer.step}, {trainer.elapsed / 60:.1f} min in all; weights: {args.out / 'motion_encoder.safetensors'}")
