"""Benchmark BlazePose tracking speed (ms per frame, frames per second).

    python -m benchmarks.bench_blazepose [VIDEO] [--frames N] [--threads T]   # from the repository root

Without VIDEO, a synthetic 1280×720 clip of a crude walking humanoid is
written to a temporary folder first. Model download/conversion and session
creation are excluded from the timing; video decoding is included (and also
reported on its own).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from lifting.blazepose.tracker import PoseTracker
from lifting.tracking import track
from lifting.video import iter_frames, video_info
from testkit.synthetic_blazepose import write_walking_clip


def decode_seconds(path: Path) -> float:
    start = time.perf_counter()
    for _ in iter_frames(path):
        pass
    return time.perf_counter() - start


def bench(path: Path, threads: int, repeats: int) -> None:
    fps, _, width, height = video_info(path)
    tracker = PoseTracker(num_threads=threads)
    track(path, tracker=tracker)  # warm-up (first-run allocations)
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        result = track(path, tracker=tracker)
        best = min(best, time.perf_counter() - start)
    n = len(result.found)
    decode = decode_seconds(path)
    print(f"video: {path.name}  {width}x{height}  {n} frames  ({fps:.2f} fps)")
    print(f"found: {result.found_fraction:.1%} of frames, detector ran on {result.detector_runs} frame(s)")
    print(f"tracking: {1000 * best / n:.1f} ms/frame, {n / best:.1f} frames/s  (best of {repeats}, {threads} threads)")
    print(f"  of which video decoding: {1000 * decode / n:.1f} ms/frame")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("video", nargs="?", type=Path, help="video file (default: synthetic 720p clip)")
    parser.add_argument("--frames", type=int, default=120, help="length of the synthetic clip")
    parser.add_argument("--threads", type=int, default=2, help="onnxruntime intra-op threads per model")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs; the best is reported")
    args = parser.parse_args(argv)
    if args.video is not None:
        bench(args.video, args.threads, args.repeats)
        return
    with tempfile.TemporaryDirectory(prefix="bench-blazepose-") as tmp:
        clip = write_walking_clip(Path(tmp) / "synthetic_720p.mp4", 1280, 720, n_frames=args.frames)
        bench(clip, args.threads, args.repeats)


if __name__ == "__main__":
    main()
