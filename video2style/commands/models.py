"""``video2style models``: the pose models a video needs (:func:`lifting.blazepose.assets.ensure_models`)."""
from __future__ import annotations

import argparse
from pathlib import Path

from video2style.commands.checks import CliError
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``models`` command's parser, on the subparsers ``sub``."""
    mo = sub.add_parser("models", help="get the pose models a video needs (one time; shows what is fetched)",
                        epilog="examples:\n  video2style models                       # fetch from PyPI once (about 36 MB)\n"
                               "  video2style models --wheel mediapipe-0.10.14-cp311-...whl   # offline\n"
                               "  video2style models --check               # exit 1 if they are missing\n\n"
                               "The BlazePose models are read from MediaPipe's wheel (Apache License 2.0), checked against\n"
                               "pinned sha256 digests and converted to ONNX in the cache folder ($VIDEO2STYLE_CACHE);\n"
                               "mediapipe itself is never installed. The other models ship inside video2style.",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    mo.add_argument("--wheel", type=Path, help="a mediapipe 0.10.14 wheel you already have (no network needed)")
    mo.add_argument("--check", action="store_true", help="only say whether they are there (exit 1 if not)")
    mo.set_defaults(func=run)


def run(args) -> None:
    from lifting.blazepose.assets import (
        WHEEL_ABOUT,
        ModelUnavailableError,
        ensure_models,
        find_models,
        model_dir,
    )

    found = find_models()
    if found is not None and args.wheel is None:
        print("BlazePose models: ready")
        for name, path in found.items():
            print(f"  {name}: {path} ({path.stat().st_size / 1e6:.1f} MB)")
        return
    if args.check:
        raise CliError(f"BlazePose models: missing from {model_dir()}; run `video2style models` (fetches {WHEEL_ABOUT}) "
                       "or `video2style models --wheel FILE.whl` offline")
    if args.wheel is not None and not args.wheel.is_file():
        raise CliError(f"{args.wheel}: no such file (expected the mediapipe wheel)")
    if args.wheel is not None:
        from lifting.blazepose.assets import MODELS

        check_outputs([("a model file", model_dir() / f"{name}.onnx") for name in MODELS], [("the --wheel file", args.wheel)])
    try:
        paths = ensure_models(wheel=args.wheel)
    except ModelUnavailableError as e:
        raise CliError(" ".join(str(e).split())) from None
    for name, path in paths.items():
        print(f"  {name}: {path}")
