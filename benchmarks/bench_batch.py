"""Items per minute of ``video2style batch``: the local loop against ``--ray`` with 1 and 2 workers.

    python benchmarks/bench_batch.py --videos VIDEO_DIR --content CLIP_DIR [--runs local ray1 ray2]

Each run starts from an empty output folder in a fresh process (``video2style batch ...``), so
learning, model loading and Ray's start are all counted. An item is one video's learning or one
(video, clip) result. Ray's overhead is the ratio of its wall time at 1 worker to the local loop's.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

RUNS = {"local": [], "ray1": ["--ray", "--workers", "1"], "ray2": ["--ray", "--workers", "2"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--videos", type=Path, required=True)
    ap.add_argument("--content", type=Path, required=True)
    ap.add_argument("--runs", nargs="+", default=list(RUNS), choices=list(RUNS))
    args = ap.parse_args()
    print(f"{'run':6s} {'items':>5s} {'failed':>6s} {'wall s':>7s} {'items/min':>9s}")
    walls = {}
    for run in args.runs:
        out = Path(tempfile.mkdtemp(prefix=f"bench_batch_{run}_"))
        t0 = time.perf_counter()
        subprocess.run(["video2style", "batch", str(args.videos), "--content", str(args.content), "-o", str(out),
                        *RUNS[run]], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
        walls[run] = time.perf_counter() - t0
        rows = json.loads((out / "report.json").read_text())
        videos = {r["video"] for r in rows}
        items = len(rows) + len(videos)
        failed = sum(r["status"] == "failed" for r in rows)
        print(f"{run:6s} {items:5d} {failed:6d} {walls[run]:7.1f} {items / walls[run] * 60:9.1f}", flush=True)
        shutil.rmtree(out, ignore_errors=True)
    if "local" in walls and "ray1" in walls:
        print(f"Ray overhead at 1 worker: {100 * (walls['ray1'] / walls['local'] - 1):+.1f} % of the local wall time")


if __name__ == "__main__":
    main()
