"""``video2style pose``: a video of one person as BVH (:func:`video2style.pose.pose_file`)."""
from __future__ import annotations

from pathlib import Path

from video2style.arguments import add_rotate, cutoff, fov
from video2style.commands.checks import CliError, writable
from video2style.paths import check_outputs


def add_parser(sub) -> None:
    """The ``pose`` command's parser, on the subparsers ``sub``."""
    po = sub.add_parser("pose", help="video of one person -> BVH on the canonical skeleton (+ preview)",
                        epilog="example: video2style pose walk.mp4 -o walk.bvh --preview walk_pose.mp4")
    po.add_argument("video", type=Path, help="a video of one person (mp4, mov, avi, mkv, webm)")
    po.add_argument("-o", "--output", type=Path, help="output .bvh (default: the video's name with .bvh)")
    po.add_argument("--preview", type=Path, help="also write an mp4: landmarks on the frames beside the fitted skeleton")
    po.add_argument("--cutoff", type=cutoff, default=3.0, help="Butterworth low-pass cutoff in Hz, 0 = off (default: %(default)s)")
    po.add_argument("--fov", type=fov, default=60.0, help="assumed horizontal field of view in degrees (default: %(default)s)")
    po.add_argument("--trajectory", default="auto", help="root path from foot contacts, the camera model, or auto (default)")
    po.add_argument("--start", type=float, help="lift the video from this time on, in seconds")
    po.add_argument("--end", type=float, help="lift the video up to this time, in seconds")
    add_rotate(po)
    po.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    po.set_defaults(func=run)


def run(args) -> None:
    from video2style.pose import pose_file

    if args.trajectory not in ("auto", "contacts", "camera"):
        raise CliError(f"pose: --trajectory expected auto, contacts or camera, got {args.trajectory!r}")
    out = writable(args.output or args.video.with_suffix(".bvh"), "-o")
    if args.preview is not None:
        writable(args.preview, "--preview")
    check_outputs([("-o", out), ("--preview", args.preview)], [("the input video", args.video)])
    info = pose_file(args.video, out, args.preview, args.cutoff or None, progress=not args.quiet,
                     fov_deg=args.fov, trajectory=args.trajectory, span=(args.start, args.end),
                     rotate=args.rotate)
    print(f"wrote {info['bvh']}: {info['bvh_frames']} frames at {info['bvh_fps']:g} fps ({info['bvh_seconds']:.2f} s), "
          f"person tracked in {info['tracked_frames']}/{info['frames']} video frames, trajectory from "
          f"{info['trajectory']}; tracking ran at {info['fps']:.1f} video frames a second"
          + (f"; preview {info['preview']}" if info["preview"] else ""))
