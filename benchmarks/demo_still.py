"""A still of the demo's results for docs/: one frame of each named preview (content | example | result), stacked.

    video2style demo -o demo_out
    python benchmarks/demo_still.py demo_out/elderly --clips walk_prior walk_turn_left_prior --frame 25 -o docs/demo_elderly.jpg

Each ``<clip>_preview.mp4`` that ``apply`` wrote holds the three panels side by side; frame ``--frame`` (0-based)
of each is taken and the rows are stacked top to bottom, in the order given.

``--side``: the previews look from the figure's front-right, where a forward lean points at the camera and hides.
With it the rows are drawn again from the BVH files (the content ``samples/<clip>.bvh``, the example
``<folder>/../pose/<style>.bvh``, the result ``<folder>/<clip>.bvh``), each panel from its figure's left side at
that frame, and each panel's label gives the trunk's forward lean (Hips -> Neck against the vertical in the hips'
facing frame, median over the clip), which is also printed:

    python benchmarks/demo_still.py demo_out/elderly --side --frame 25 -o docs/demo_elderly_side.jpg
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def preview_frame(path: Path, index: int):
    """Frame ``index`` (0-based) of the video at ``path`` as an ``(H, W, 3)`` BGR array; ValueError if it has none."""
    import cv2

    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise ValueError(f"{path}: cannot be read as a video")
        for _ in range(index + 1):
            ok, frame = cap.read()
            if not ok:
                raise ValueError(f"{path}: has no frame {index}")
        return frame
    finally:
        cap.release()


def side_row(files: list[Path], labels: list[str], index: int, size: tuple[int, int] = (360, 360)):
    """One row of panels, each file's canonical BVH drawn at frame ``index`` from its figure's left side, 3.4 m away;
    returns the image and the trunk leans (degrees)."""
    import math

    from evaluation.metrics import trunk_lean
    from motioncore.bvh import read_bvh
    from motioncore.render import Panel, render_frame
    from motioncore.representation import facing_angle

    panels, leans = [], []
    for path, label in zip(files, labels):
        motion, _ = read_bvh(path)
        gpos = motion.global_positions().float()
        yaw = float(facing_angle(gpos[min(index, motion.num_frames - 1)]))  # forward = (sin, 0, cos); left = (cos, 0, -sin)
        lean = trunk_lean(motion)
        leans.append(lean)
        eye = (3.3 * math.cos(yaw), 0.6, -3.3 * math.sin(yaw))
        panels.append(Panel(gpos, motion.skeleton.parents, f"{label}: trunk lean {lean:.0f} deg",
                            names=motion.skeleton.names, eye=eye))
    return render_frame(panels, index, size, fps=motion.fps), leans


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path, help="a style's output folder of `video2style demo` or `apply`")
    ap.add_argument("--clips", nargs="+", default=["walk_prior", "walk_turn_left_prior"], help="clip stems, one row each")
    ap.add_argument("--frame", type=int, default=25, help="frame to take from each preview (default: %(default)s)")
    ap.add_argument("--side", action="store_true", help="draw the rows from the BVH files, seen from the side, "
                    "with the trunk's lean (see above)")
    ap.add_argument("-o", "--out", type=Path, required=True, help="the still (.jpg or .png)")
    args = ap.parse_args(argv)
    import cv2
    import numpy as np

    from motioncore.files import atomic_output

    try:
        if args.side:
            from video2style.demo import SAMPLES

            style = args.folder.name
            rows = []
            for c in args.clips:
                files = [SAMPLES / f"{c}.bvh", args.folder.parent / "pose" / f"{style}.bvh", args.folder / f"{c}.bvh"]
                missing = [f for f in files if not f.is_file()]
                if missing:
                    raise ValueError(f"{missing[0]}: no such file")
                row, leans = side_row(files, ["content", f"style: {style}", "result"], args.frame)
                print(f"{c}: trunk lean content {leans[0]:.1f}, example {leans[1]:.1f}, result {leans[2]:.1f} degrees")
                rows.append(row)
        else:
            rows = [preview_frame(args.folder / f"{c}_preview.mp4", args.frame) for c in args.clips]
    except ValueError as e:
        print(f"demo_still.py: {e}", file=sys.stderr)
        return 2
    with atomic_output(args.out, args.out.suffix) as tmp:
        if not cv2.imwrite(str(tmp), np.vstack(rows), [cv2.IMWRITE_JPEG_QUALITY, 85]):
            print(f"demo_still.py: {args.out}: could not be written", file=sys.stderr)
            return 2
    print(f"wrote {args.out} ({len(rows)} rows, frame {args.frame})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
