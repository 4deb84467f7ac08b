"""``video2style skeleton``: which joint of a clip plays each role (:mod:`video2style.rig_report`)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from video2style.commands.checks import writable
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``skeleton`` command's parser, on the subparsers ``sub``."""
    from video2style.interchange import add_arguments as add_clip_format_arguments

    sk = sub.add_parser("skeleton", help="show which joint of a BVH file plays each role (and write a joint map)",
                        epilog="examples:\n  video2style skeleton mixamo_walk.bvh\n"
                               "  video2style skeleton rig.bvh --write-map map.json --preview roles.png\n"
                               "  video2style skeleton rig.bvh --joint-map map.json   # check your edits\n\n"
                               "Roles are found from the hierarchy and the rest pose (T or A pose, any up axis, any\n"
                               "units); names only tell left from right when the feet cannot. A joint map is rarely\n"
                               "needed: write one here, fix the roles that are wrong, and pass it to learn/apply.\n"
                               "A map may be partial: it overrides only the roles it names (null: no such bone).",
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    sk.add_argument("file", type=Path, help="a BVH file (or an FBX, GLB, glTF clip)")
    sk.add_argument("--write-map", type=Path, metavar="MAP.json", help="write the mapping as an editable joint map")
    sk.add_argument("--preview", type=Path, metavar="IMAGE.png", help="draw the pose read with the roles coloured")
    sk.add_argument("--joint-map", type=Path, metavar="MAP.json", help="your map: overrides the roles it names")
    add_clip_format_arguments(sk)
    sk.set_defaults(func=run)


def run(args) -> None:
    from motioncore.retarget import RetargetError, load_joint_map
    from video2style.rig_report import (
        inspect_skeleton,
        render_roles,
        report_lines,
        write_map,
        write_template,
    )

    if args.write_map:
        writable(args.write_map, "--write-map")
    if args.preview:
        writable(args.preview, "--preview")
    check_outputs([("--write-map", args.write_map), ("--preview", args.preview)],
                  [("the input clip", args.file), ("the --joint-map", args.joint_map)])
    joint_map = load_joint_map(args.joint_map) if args.joint_map else None
    from video2style.interchange import as_bvh

    source, args.file = args.file, as_bvh(args, args.file)  # an FBX/glTF clip: its armature as BVH
    try:
        rep = inspect_skeleton(args.file, joint_map)
        rep.path = source
    except RetargetError:
        if args.write_map and args.joint_map is None:  # a template to fill in
            names = write_template(args.file, args.write_map)
            print(f"wrote {args.write_map}: a template; put your joint's name for each role and pass it with "
                  f"--joint-map (null only for Spine, Neck, Shoulder_L/R, Toes_L/R). Your joints: {', '.join(names)}",
                  file=sys.stderr)
        raise
    print("\n".join(report_lines(rep)))
    if args.write_map:
        print(f"wrote {write_map(rep, args.write_map)} (edit it, then pass --joint-map {args.write_map})")
    if args.preview:
        print(f"wrote {render_roles(rep, args.preview)}")
