"""A still of the demo's results for docs/: one frame of each named preview (content | example | result), stacked.

    video2style demo -o demo_out
    python benchmarks/demo_still.py demo_out/elderly --clips walk_prior walk_turn_left_prior --frame 25 -o docs/demo_elderly.jpg

Each ``<clip>_preview.mp4`` that ``apply`` wrote holds the three panels side by side; frame ``--frame`` (0-based)
of each is taken and the rows are stacked top to bottom, in the order given.
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", type=Path, help="a style's output folder of `video2style demo` or `apply`")
    ap.add_argument("--clips", nargs="+", default=["walk_prior", "walk_turn_left_prior"], help="clip stems, one row each")
    ap.add_argument("--frame", type=int, default=25, help="frame to take from each preview (default: %(default)s)")
    ap.add_argument("-o", "--out", type=Path, required=True, help="the still (.jpg or .png)")
    args = ap.parse_args(argv)
    import cv2
    import numpy as np

    from motioncore.files import atomic_output

    try:
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
