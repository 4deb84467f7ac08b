"""``video2style pose`` against MediaPipe 0.10.14's own Pose solution (same full landmark model), whole commands.

    pip install --target /tmp/mp mediapipe==0.10.14 --no-deps
    pip install --target /tmp/mp "protobuf>=4.25.3,<5" absl-py attrs flatbuffers --no-deps
    python benchmarks/compare_mediapipe.py --mediapipe /tmp/mp VIDEO [VIDEO ...]

MediaPipe is never a dependency of video2style: it lives in its own folder, put on PYTHONPATH only
for its side of the comparison. Each side is a fresh process, timed from start to exit: ours
reads the video, tracks, lifts, filters, fits the skeleton and writes the BVH; MediaPipe's reads
the video and runs ``mp.solutions.pose.Pose(model_complexity=1)`` on every frame (landmarks only).
The two commands alternate ``--repeats`` times (so a busy spell hits both); each side's best time counts,
and the median of the ratios of the alternating pairs is printed beside it. Both run under this interpreter
without wrappers: ours as the ``video2style`` console script beside ``sys.executable`` (a pyenv
shim on PATH would add ~50 ms of shell to our side only), theirs as ``sys.executable -c``.
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MEDIAPIPE = r"""
import sys, cv2, mediapipe as mp
pose = mp.solutions.pose.Pose(model_complexity=1, static_image_mode=False)
cap = cv2.VideoCapture(sys.argv[1])
while True:
    ok, frame = cap.read()
    if not ok:
        break
    pose.process(cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
"""


def run_seconds(cmd: list[str], env: dict | None = None) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("videos", nargs="+", type=Path)
    ap.add_argument("--mediapipe", type=Path, required=True, help="folder holding mediapipe 0.10.14 (pip --target)")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    import cv2

    from video2style.paths import console_script

    ours_cmd = console_script()
    env = dict(os.environ, PYTHONPATH=str(args.mediapipe), GLOG_minloglevel="3", TF_CPP_MIN_LOG_LEVEL="3")
    print(f"{'video':34s} {'frames':>6s} {'ours s':>7s} {'MediaPipe s':>11s} {'ours/MP':>8s} {'pairs median':>12s}")
    ratios = []
    with tempfile.TemporaryDirectory() as tmp:
        for video in args.videos:
            frames = int(cv2.VideoCapture(str(video)).get(cv2.CAP_PROP_FRAME_COUNT))
            ours_run = [str(ours_cmd), "pose", str(video), "-o", str(Path(tmp) / "out.bvh"), "-q"]
            theirs_run = [sys.executable, "-c", MEDIAPIPE, str(video)]
            pairs = [(run_seconds(ours_run), run_seconds(theirs_run, env)) for _ in range(args.repeats)]
            ours, theirs = min(p[0] for p in pairs), min(p[1] for p in pairs)
            ratios.append(ours / theirs)
            paired = statistics.median(a / b for a, b in pairs)
            print(f"{video.name:34s} {frames:6d} {ours:7.2f} {theirs:11.2f} {ours / theirs:8.2f} {paired:12.2f}", flush=True)
    print(f"geometric mean ours/MediaPipe: {math.exp(sum(map(math.log, ratios)) / len(ratios)):.2f} "
          "(below 1: ours faster)")


if __name__ == "__main__":
    main()
