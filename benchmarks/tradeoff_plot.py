"""One trade-off plot (CRA against SRA) from several ``evaluate`` runs, e.g. the seen-style protocol and the
unseen-style protocol side by side:

    python benchmarks/tradeoff_plot.py runs/eval_full/rows.json runs/eval_unseen/rows.json -o docs/tradeoff.png

Each run's rows keep their names (the unseen protocol marks them "[held-out]" and "[seen]"); ``--label`` puts a
prefix on each run's curves when two runs have rows of the same name.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("rows", nargs="+", type=Path, help="rows.json files written by video2style evaluate")
    ap.add_argument("--label", nargs="*", default=None, help="a prefix per file (default: none)")
    ap.add_argument("-o", "--out", type=Path, required=True)
    ap.add_argument("--title", default="CRA against SRA at --strength 0.25 ... 1")
    args = ap.parse_args()
    if args.label is not None and len(args.label) != len(args.rows):
        ap.error(f"--label: expected {len(args.rows)} labels, got {len(args.label)}")

    from video2style.evaluate import plot_tradeoff

    rows = []
    for k, path in enumerate(args.rows):
        for r in json.loads(path.read_text()):
            if r["method"].startswith("real"):
                continue
            if args.label:
                r = dict(r, method=f"{args.label[k]} {r['method']}")
                if "base_method" in r:
                    r["base_method"] = f"{args.label[k]} {r['base_method']}"
            rows.append(r)
    print(plot_tradeoff(rows, args.out, title=args.title))


if __name__ == "__main__":
    main()
