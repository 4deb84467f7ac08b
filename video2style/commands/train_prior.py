"""``video2style train-prior``: train or resume the motion prior (:func:`transfer.prior.train_prior`)."""
from __future__ import annotations

from pathlib import Path

from video2style.arguments import (
    add_device,
    add_exclude_styles,
    explicit_settings,
    finite_positive,
    non_negative,
    non_negative_int,
    positive,
    positive_int,
    style_option,
)
from video2style.commands.checks import run_folder_checks


def add_parser(sub) -> None:
    """The ``train-prior`` command's parser, on the subparsers ``sub``."""
    from video2style.paths import cache_dir, default_dataset_dir

    t = sub.add_parser("train-prior", help="train (or resume) the text-conditioned motion diffusion prior")
    t.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    t.add_argument("--out", type=Path, default=cache_dir() / "runs" / "prior", help="run folder (default: %(default)s)")
    t.add_argument("--max-minutes", type=positive, default=60.0, help="stop after this long; run again to resume (default: %(default)s)")
    t.add_argument("--max-steps", type=int, default=10**9, help="stop at this many optimiser steps in all (default: %(default)s)")
    for name, typ in [("width", positive_int), ("layers", positive_int), ("heads", positive_int), ("ff", positive_int),
                      ("batch_size", positive_int), ("window", positive_int), ("lr", finite_positive),
                      ("seed", style_option("seed")), ("decay_start", non_negative_int), ("decay_steps", non_negative_int)]:
        t.add_argument(f"--{name.replace('_', '-')}", dest=name, type=typ, default=None,
                       help="default: see transfer.prior.PriorTrainConfig; a resumed run keeps its own")
    t.add_argument("--precision", choices=["fp32", "bf16"], default=None,
                   help="bf16: the training forward under bfloat16 autocast, 1.6x faster on CPUs with avx512_bf16 "
                        "(default: fp32; a resumed run may change it)")
    t.add_argument("--fk-weight", dest="fk_weight", type=non_negative, default=None,
                   help="weight of the FK consistency term (the joints the predicted rotations place against the "
                        "clip's joint positions, cm^2); the campaign's last stage: 0.05 (default: 0; a resumed run "
                        "may change it)")
    t.add_argument("--contact-weight", dest="contact_weight", type=non_negative, default=None,
                   help="weight of the foot-contact term (how far the feet the model says are planted move over the "
                        "ground, (cm/frame)^2, as MDM's) (default: 0; a resumed run may change it)")
    t.add_argument("--derive-positions", dest="derive_positions", action="store_const", const=True, default=None,
                   help="derive the output's joint-position channels from its rotation channels instead of predicting "
                        "them (a resumed run may turn it on)")
    t.add_argument("--val-every", dest="val_every", type=int, default=None,
                   help="steps between validation losses, logged to OUT/val.csv (default: 250; 0: none)")
    add_exclude_styles(t)
    add_device(t)
    t.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    t.set_defaults(func=run)


def run(args) -> None:
    from transfer.prior import PriorTrainConfig, convergence, read_val_log, train_prior

    run_folder_checks(args, ["checkpoint.safetensors", "denoiser.safetensors", "denoiser.json", "val.csv"])
    explicit = explicit_settings(args, PriorTrainConfig)
    config = PriorTrainConfig(**explicit)
    trainer = train_prior(args.data, args.out, config, args.max_minutes, args.max_steps, explicit, progress=not args.quiet,
                          device=args.device)
    print(f"step {trainer.step}, {trainer.elapsed / 60:.1f} min in all; weights: {args.out / 'denoiser.safetensors'}")
    log = read_val_log(args.out / "val.csv")
    fall = convergence(log)
    if fall is not None:
        verdict = "converged (< 2 %)" if fall < 0.02 else "not converged yet: run again to continue"
        print(f"validation loss {log[-1][1]:.4f} at step {log[-1][0]}; fell {100 * fall:.1f} % over the last fifth "
              f"of the steps: {verdict}")
