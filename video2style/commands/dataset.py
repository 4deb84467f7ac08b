"""``video2style dataset``: the training cache from the Bandai-Namco archives (:func:`mlcore.dataset.build_dataset`)."""
from __future__ import annotations

import sys
from pathlib import Path

from video2style.arguments import style_option
from video2style.commands.checks import CliError
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``dataset`` command's parser, on the subparsers ``sub``."""
    from video2style.paths import default_dataset_dir

    d = sub.add_parser("dataset", help="build the training cache from the Bandai-Namco archives")
    d.add_argument("--bandai2", type=Path, help="Bandai-Namco-Research-Motiondataset-2 .tar.xz")
    d.add_argument("--bandai1", type=Path, help="Bandai-Namco-Research-Motiondataset-1 (seen styles) .tar.xz")
    d.add_argument("-o", "--out", type=Path, default=default_dataset_dir(), help="cache folder (default: %(default)s)")
    d.add_argument("--seed", type=style_option("seed"), default=0, help="split seed (default: %(default)s)")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    d.set_defaults(func=run)


def run(args) -> None:
    from mlcore.dataset import build_dataset

    archives = [a for a in (args.bandai2, args.bandai1) if a is not None]
    if not archives:
        raise CliError("dataset: give --bandai2 and/or --bandai1 (the .tar.xz archives)")
    for a in archives:
        if not a.is_file():
            raise CliError(f"{a}: no such file")
    check_outputs([("-o", args.out / name) for name in ("features.safetensors", "clips.json", "split.json")],
                  [("the archive", a) for a in archives])
    summary = build_dataset(archives, args.out, seed=args.seed, progress=not args.quiet)
    print(f"wrote {args.out} in {summary['seconds']:.0f} s: {summary['clips']} clips (mirrored copies included)")
    for name, s in summary["splits"].items():
        print(f"  {name:5s} {s['clips']:5d} clips {s['frames']:7d} frames {s['hours']:.2f} h")
    for f in summary["failed"]:
        print(f"  skipped {f}", file=sys.stderr)
