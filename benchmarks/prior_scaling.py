"""Validation loss against time and steps for several prior training runs (issue 24's scaling study):

    video2style train-prior --out runs/scale_4x256 --max-minutes 45            # one thread each, side by side
    video2style train-prior --out runs/scale_6x384 --width 384 --layers 6 --heads 6 --ff 768 --max-minutes 45
    python benchmarks/prior_scaling.py runs/scale_4x256 runs/scale_6x384 [--at 600 1200 1800 2400]

Reads each run's ``log.csv`` (step, seconds) and ``val.csv`` (the fixed validation loss) and prints the validation
loss each run had reached after the given seconds of training, its steps per second, and its last value.
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path


def _read(path: Path) -> list[dict]:
    with path.open() as f:
        return list(csv.DictReader(f))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path, help="train-prior run folders")
    ap.add_argument("--at", nargs="+", type=float, default=[600, 1200, 1800, 2400], help="seconds of training")
    args = ap.parse_args()
    print("run | steps/s | " + " | ".join(f"val @ {t:g} s" for t in args.at) + " | last (step: val)")
    for run in args.runs:
        log, val = _read(run / "log.csv"), _read(run / "val.csv")
        if not log or not val:
            raise SystemExit(f"{run}: expected log.csv and val.csv with rows")
        seconds = {int(r["step"]): float(r["time_s"]) for r in log}
        points = [(seconds.get(int(r["step"])), int(r["step"]), float(r["val_loss"])) for r in val]
        points = [p for p in points if p[0] is not None]
        last_step = max(seconds)
        rate = last_step / seconds[last_step]
        cells = []
        for t in args.at:
            reached = [p for p in points if p[0] <= t]
            cells.append(f"{reached[-1][2]:.4f} (step {reached[-1][1]})" if reached and seconds[last_step] >= t else "–")
        print(f"{run.name} | {rate:.2f} | " + " | ".join(cells) + f" | {points[-1][1]}: {points[-1][2]:.4f}")


if __name__ == "__main__":
    main()
