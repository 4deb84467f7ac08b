"""When each phase of ``video2style pose`` ends, in one fresh process: tracking (in a child process when
torch is still loading) against the import of the torch side, then the lift and the BVH.

    python benchmarks/trace_pose.py VIDEO [--runs 3]

Each run starts a new interpreter that wraps ``lifting.preload`` and ``lifting.track_process`` with
timestamps (seconds since the run's ``subprocess`` start) and runs ``video2style pose VIDEO -q`` as the console
script does (``console_main``); the last line is when the process has ended, interpreter exit included.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PROBE = r"""
import os, sys, time
T0 = float(os.environ["TRACE_T0"])
def mark(s): print(f"{time.time() - T0:6.3f} s  {s}", file=sys.stderr, flush=True)
mark("python up")
from lifting import preload
import lifting.track_process as tp
start, finish, child = preload.start, preload.finish, tp.track_in_child
def traced_start(n): mark("import of the torch side starts"); start(n)
def traced_finish(n): mark("tracking done, waiting for the import"); m = finish(n); mark("import done"); return m
def traced_child(*a): mark("child process starts tracking"); r = child(*a); mark("child done"); return r
preload.start, preload.finish, tp.track_in_child = traced_start, traced_finish, traced_child
from video2style.cli import console_main
sys.argv = ["video2style", "pose", sys.argv[1], "-o", sys.argv[2], "-q"]
code = console_main()
mark("BVH written, interpreter exits")
sys.exit(code)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("video", type=Path)
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for run in range(args.runs):
            print(f"run {run + 1}:", file=sys.stderr, flush=True)
            t0 = time.time()
            env = dict(os.environ, TRACE_T0=repr(t0))
            subprocess.run([sys.executable, "-c", PROBE, str(args.video), str(Path(tmp) / "out.bvh")], env=env,
                           stdout=subprocess.DEVNULL, check=True)
            print(f"{time.time() - t0:6.3f} s  process ended", file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()
