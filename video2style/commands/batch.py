"""``video2style batch``: every style applied to a library, resumable (:func:`video2style.batch.run_batch`, on Ray
:func:`video2style.batch_ray.run_batch_ray`)."""
from __future__ import annotations

import argparse
from pathlib import Path

from video2style.arguments import add_device, add_rotate, positive_int
from video2style.commands.checks import STYLE_FILE_BYTES, CliError, free_space, writable


def add_parser(sub) -> None:
    """The ``batch`` command's parser, on the subparsers ``sub``."""
    b = sub.add_parser("batch", help="learn (or reuse) each style and apply it to a BVH/FBX library (resumable)",
                       epilog="examples:\n  video2style batch videos/ --content library/ -o results/\n"
                              "  video2style batch old.v2s strut.mp4 proud.bvh --content library/ -o results/ --tempo auto\n\n"
                              "Style sources may be mixed: videos, BVH/FBX/GLB/glTF example clips and style files from\n"
                              "`video2style learn` (used as they are, not learned again); a folder gives its videos and\n"
                              "style files. The apply options mean what they mean for `video2style apply`.",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    b.add_argument("inputs", type=Path, nargs="+", metavar="STYLE",
                   help="videos, example clips (.bvh, .fbx, .glb, .gltf), style files (.v2s), or folders of videos "
                        "and style files")
    b.add_argument("--content", type=Path, required=True, help="folder of BVH (or FBX, GLB, glTF) clips, searched recursively; "
                   "FBX/glTF results keep their format unless --format")
    b.add_argument("-o", "--output", type=Path, required=True, help="output folder: styles/, one folder per style, index.html")
    from video2style.options import add_apply_options

    add_apply_options(b)  # apply's options, from its own definition
    b.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                   help="run on Ray (pip install \"video2style[ray]\"): alone, a local Ray on this machine; "
                        "auto or ray://host:port joins a cluster (OUT must then be a folder every node sees)")
    b.add_argument("--workers", type=positive_int, help="--ray without an address: CPUs to use (default: all)")
    add_rotate(b)
    add_device(b)
    b.set_defaults(func=run)


def run(args) -> None:
    from video2style.batch import run_batch
    from video2style.options import apply_options

    options = apply_options(args)  # the same options, checked the same way, as apply's
    writable(args.output, "-o", is_dir=True)
    free_space(args.output / "styles" / "style.v2s", STYLE_FILE_BYTES, "-o")  # room for at least one style
    if args.ray is not None:
        from video2style.batch_ray import run_batch_ray

        report = run_batch_ray(args.inputs, args.content, args.output, options=options,
                               address=None if args.ray == "local" else args.ray, workers=args.workers, device=args.device,
                               rotate=args.rotate)
    else:
        if args.workers is not None:
            raise CliError("batch: --workers goes with --ray")
        report = run_batch(args.inputs, args.content, args.output, options=options, device=args.device,
                           rotate=args.rotate)
    print(report.table())
    print(f"report: {args.output / 'report.json'}")
    print(f"index: {args.output / 'index.html'}")
    if report.failures:
        raise CliError(f"{len(report.failures)} item(s) failed (see the table)")
