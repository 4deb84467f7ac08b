"""``video2style evaluate``: the transfer protocols (:func:`video2style.evaluate.evaluate`, :func:`video2style.evaluate.evaluate_dev_styles`)."""
from __future__ import annotations

import argparse
from pathlib import Path

from video2style.arguments import style_option
from video2style.commands.checks import CliError, data_inputs
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``evaluate`` command's parser, on the subparsers ``sub``."""
    from video2style.methods import ALIASES, METHODS
    from video2style.paths import default_dataset_dir

    ev = sub.add_parser("evaluate", help="Bandai-2 transfer protocol (Hu et al. 4.2): FMD, CRA, SRA, foot skating",
                        epilog="examples:\n  video2style evaluate --quick --methods identity park ours\n"
                               "  video2style evaluate --unseen --quick --split val --methods identity ours",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ev.add_argument("--data", type=Path, default=default_dataset_dir(), help="dataset cache (default: %(default)s)")
    ev.add_argument("-o", "--out", type=Path, default=Path("eval_out"), help="folder for table.md, rows.json, tradeoff.png")
    ev.add_argument("--quick", action="store_true", help="120 transfers with one example per style (default: full, 3780)")
    ev.add_argument("--methods", nargs="+", default=["identity", "park", "ours"], metavar="METHOD",
                    help=f"some of {', '.join(METHODS)}; older names run as the method they stand for: "
                         f"{', '.join(f'{a} ({b})' for a, b in ALIASES.items())} (default: %(default)s)")
    ev.add_argument("--iterations", type=style_option("iterations"), help="learning iterations per style example (default: learn's)")
    ev.add_argument("--strengths", type=float, nargs="+", help="run each variant of ours at these --strength values "
                    "(one row each; tradeoff.png draws the curves)")
    ev.add_argument("--style-cache", type=Path, help="keep learned styles in this folder and reuse them in later runs")
    ev.add_argument("--split", choices=["test", "val"], default="test",
                    help="clips to evaluate on: val to choose settings, test to report (default: %(default)s)")
    ev.add_argument("--examples-pool", type=int, help="style examples drawn from this many clips per style (default with an ours method: 1 quick, 3 full; otherwise all)")
    ev.add_argument("--park-weights", "--stgcn-weights", dest="park_weights", type=Path,
                    help="Park stylizer weights for park/park-raw (default: the shipped ones; --stgcn-weights: the "
                         "older name)")
    ev.add_argument("--seed", type=style_option("seed"), default=0,
                    help="seed for example draws and noise (default: %(default)s)")
    ev.add_argument("--dev-styles", type=Path, metavar="DIR",
                    help="the second unseen-style protocol: the folder holding bandai1-unseen-dev-styles.tar.xz and "
                         "bandai1-seen-styles.tar.xz (five Bandai-1 styles no model saw, each learned from its walk and "
                         "applied to ten neutral actions; hand-feature judges); --strengths S: its first value; "
                         "--methods ours-calibrated: each style calibrated (learn --calibrate)")
    ev.add_argument("--unseen", action="store_true",
                    help="the unseen-style protocol: models trained without three styles (elderly, exhausted, feminine), "
                         "neutral content to those styles and, from the same models, to the others")
    ev.add_argument("--unseen-models", type=Path, metavar="DIR",
                    help="--unseen: the folder with the held-out denoiser.safetensors and motion_encoder.safetensors "
                         "(default: the development weights in evaluation/weights/unseen)")
    ev.add_argument("--groups", nargs="+", choices=("held-out", "seen"), default=["held-out", "seen"],
                    help="--unseen: the target groups to run (default: both)")
    ev.add_argument("--style-words", metavar="WORDS",
                    help="learn every style under these words instead of its name (e.g. qwxz: a name that means "
                         "nothing to the encoders)")
    ev.set_defaults(func=run)


def run(args) -> None:
    from video2style.evaluate import evaluate, evaluate_dev_styles

    if args.dev_styles is not None:
        archives = [args.dev_styles / name for name in ("bandai1-unseen-dev-styles.tar.xz", "bandai1-seen-styles.tar.xz")]
        missing = [str(a) for a in archives if not a.is_file()]
        if missing:
            raise CliError(f"evaluate --dev-styles: no {missing[0]}")
        check_outputs([("-o", args.out), ("-o", args.out / "dev_styles.md"), ("-o", args.out / "dev_styles.json")],
                      [("--dev-styles", a) for a in archives])
        calibrate = args.methods is not None and "ours-calibrated" in args.methods
        for line in evaluate_dev_styles(*archives, args.out, strength=0.5 if args.strengths is None else args.strengths[0],
                                        seed=args.seed, calibrate=calibrate, style_cache=args.style_cache):
            print(line)
        return
    inputs = data_inputs(args.data) + [("the --park-weights file", args.park_weights),
                                        ("the --unseen-models folder", args.unseen_models)]
    check_outputs([("-o", args.out)] + [("-o", args.out / name) for name in ("table.md", "rows.json", "tradeoff.png")], inputs)
    check_outputs([("--style-cache", args.style_cache)], inputs)
    for line in evaluate(args.data, args.out, quick=args.quick, methods=args.methods, seed=args.seed,
                         examples_pool=args.examples_pool, park_weights=args.park_weights, split=args.split,
                         strengths=args.strengths, iterations=args.iterations, style_cache=args.style_cache,
                         unseen=args.unseen, unseen_models=args.unseen_models, words=args.style_words,
                         groups=args.groups):
        print(line)
