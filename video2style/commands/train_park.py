"""``video2style train-park``: train or resume Park et al.'s stylizer (:func:`park.train.train_park`)."""
from __future__ import annotations

from pathlib import Path

from video2style.arguments import add_device, positive, positive_int, style_option
from video2style.commands.checks import run_folder_checks


def add_parser(sub) -> None:
    """The ``train-park`` command's parser, on the subparsers ``sub``."""
    from video2style.paths import cache_dir, default_dataset_dir

    tp = sub.add_parser("train-park", help="train (or resume) Park et al.'s ST-GCN stylizer on the Bandai-2 styles")
    tp.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    tp.add_argument("--out", type=Path, default=cache_dir() / "runs" / "park", help="run folder (default: %(default)s)")
    tp.add_argument("--weights", type=Path, help="exported weights (default: park_stylizer.safetensors in the run folder; "
                    "name the package's mlcore/weights/ file to replace the shipped ones)")
    tp.add_argument("--max-minutes", type=positive, default=60.0, help="stop after this long; run again to resume (default: %(default)s)")
    tp.add_argument("--max-steps", type=int, default=100_000, help="stop at this many optimiser steps in all (default: %(default)s)")
    tp.add_argument("--threads", type=int, default=0, help="torch threads (default: torch's choice; 1 while other work runs)")
    add_device(tp)
    for name in ("batch_size", "window", "seed", "ds_decay_steps"):
        tp.add_argument(f"--{name.replace('_', '-')}", dest=name,
                        type={"seed": style_option("seed"), "ds_decay_steps": int}.get(name, positive_int),
                        default=None,
                        help="default: see park.train.ParkTrainConfig; a resumed run keeps its own")
    tp.add_argument("--lambda-ds", type=float, default=None,
                    help="weight of the diversity-sensitive loss (default 1, as in the paper)")
    tp.add_argument("--init", type=Path, default=None,
                    help="start a new run from exported weights (G/E/F; D fresh), e.g. to fine-tune with another --lambda-ds")
    tp.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    tp.set_defaults(func=run)


def run(args) -> None:
    import dataclasses

    import torch

    from park.train import ParkTrainConfig, default_weights, train_park

    explicit = {k: getattr(args, k) for k in ("batch_size", "window", "seed", "ds_decay_steps") if getattr(args, k) is not None}
    config = ParkTrainConfig(**explicit)
    if args.lambda_ds is not None:
        config.weights = dataclasses.replace(config.weights, ds=args.lambda_ds)
        explicit["weights"] = dataclasses.asdict(config.weights)
    if args.init is not None and not args.init.is_file():
        raise SystemExit(f"error: {args.init}: no such weights file (--init)")
    weights = args.weights or args.out / default_weights().name  # the shipped file only when named
    run_folder_checks(args, ["checkpoint.safetensors", "log.csv"], [("the --init weights", args.init)],
                       [("--weights", weights), ("--weights", weights.with_suffix(".json"))])
    if args.threads:
        torch.set_num_threads(args.threads)
    card = train_park(args.data, args.out, config, args.max_minutes, args.max_steps,
                      weights, explicit, progress=not args.quiet, init_path=args.init, device=args.device)
    print(f"step {card.get('steps', '?')}; weights: {weights}")
