"""``video2style preview``: BVH clips side by side in an mp4 (:func:`video2style.preview.preview_bvh_files`)."""
from __future__ import annotations

import sys
from pathlib import Path

from video2style.commands.checks import CliError, writable
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``preview`` command's parser, on the subparsers ``sub``."""
    from video2style.interchange import add_arguments as add_clip_format_arguments

    v = sub.add_parser("preview", help="render BVH clips side by side to an mp4",
                       epilog="example: video2style preview a.bvh b.bvh --canonical -o ab.mp4")
    v.add_argument("clips", nargs="+", type=Path, help="BVH (or FBX, GLB, glTF) clips, drawn side by side")
    v.add_argument("-o", "--output", type=Path, required=True, help="output .mp4")
    v.add_argument("--canonical", action="store_true", help="retarget to the canonical skeleton first")
    v.add_argument("--joint-map", type=Path, help="rarely needed: skeletons are mapped automatically (see `video2style skeleton FILE`); a JSON map of canonical role -> your joint name overrides the roles it names")
    add_clip_format_arguments(v)
    v.set_defaults(func=run)


def run(args) -> None:
    from motioncore.retarget import load_joint_map
    from video2style.preview import preview_bvh_files

    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    writable(args.output, "-o")
    check_outputs([("-o", args.output)], [("the input clip", c) for c in args.clips] + [("the --joint-map", args.joint_map)])
    if args.output.suffix.lower() != ".mp4":
        raise CliError(f"{args.output}: previews are .mp4 videos; give -o NAME.mp4")
    from video2style.interchange import as_bvh

    clips = [as_bvh(args, c) for c in args.clips]  # an FBX/glTF clip: its action as BVH (one Blender for all)
    out = preview_bvh_files(clips, args.output, canonical=args.canonical, joint_map=joint_map,
                            notify=lambda s: print(s, file=sys.stderr))
    print(f"wrote {out}")
