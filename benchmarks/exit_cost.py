"""What the interpreter's exit costs after torch is imported, and what ``gc.freeze()`` in the console
script (``video2style.cli.console_main``) saves on whole commands.

    python benchmarks/exit_cost.py --style STYLE.v2s [--runs 8]

Every variant is a fresh process, the variants alternate (so a busy spell of a shared machine hits
them all) and each prints its median and best wall time:

- ``import torch`` then a normal exit / ``gc.freeze()`` then a normal exit / ``os._exit(0)`` (no cleanup
  at all, for reference only);
- ``video2style apply STYLE samples/walk_prior.bvh --no-preview`` and ``video2style --help``, each through
  ``main()`` with a normal exit and through the console script beside ``sys.executable``.
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MAIN = "import sys; from video2style.cli import main; sys.exit(main(sys.argv[1:]))"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--style", type=Path, required=True, help="a style file from `video2style learn`")
    ap.add_argument("--runs", type=int, default=8)
    args = ap.parse_args()
    from video2style.demo import SAMPLES
    from video2style.paths import console_script

    script = console_script()
    with tempfile.TemporaryDirectory() as tmp:
        apply = ["apply", str(args.style), str(SAMPLES / "walk_prior.bvh"), "-o", tmp, "--no-preview"]
        variants = {
            "import torch; normal exit": [sys.executable, "-c", "import torch"],
            "import torch; gc.freeze(); normal exit": [sys.executable, "-c", "import gc, torch; gc.freeze()"],
            "import torch; os._exit(0)": [sys.executable, "-c", "import os, torch; os._exit(0)"],
            "apply via main(); normal exit": [sys.executable, "-c", MAIN, *apply],
            "apply via the console script": [str(script), *apply],
            "--help via main(); normal exit": [sys.executable, "-c", MAIN, "--help"],
            "--help via the console script": [str(script), "--help"],
        }
        times: dict[str, list[float]] = {name: [] for name in variants}
        for _ in range(args.runs):
            for name, cmd in variants.items():
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                times[name].append(time.perf_counter() - t0)
    print(f"{'variant':42s} {'median s':>8s} {'best s':>7s}   ({args.runs} alternating runs)")
    for name, t in times.items():
        print(f"{name:42s} {statistics.median(t):8.2f} {min(t):7.2f}")


if __name__ == "__main__":
    main()
