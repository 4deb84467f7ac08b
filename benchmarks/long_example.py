"""What a long style example costs learn and apply, with and without the bounds of issue 25 (part B).

    python -m benchmarks.long_example [--seconds 180] [--iterations 2] [--out /tmp/long_example]
    python -m benchmarks.long_example --choose-only --seconds 18000 --fps 1   # a 5-hour take at 1 fps

learn: ``learn_file`` on a synthetic ``--seconds`` BVH (a smooth random walk, 20 fps), ``--iterations`` iterations,
once as it is now (the most typical 20 s of the input) and once with the bound lifted (the whole input, as before);
prints each run's seconds for the pair, the iterations and in all. apply: ``LoadedStyle.apply`` on a 1 s clip with a style
whose stored example is the whole long input (a style file learned before the bound), its preview's example panel
capped to the clip (now) and uncapped (before). ``--choose-only``: a ``--seconds`` take at ``--fps`` read and its
part chosen, as learn does before learning (time and the process's peak memory). Run from the repository root (it
uses tests/helpers.py).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from motioncore.bvh import BvhLayout, write_bvh
from motioncore.representation import encode
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion
from transfer.bundle import load_models
from transfer.style_config import LearnConfig
from transfer.style_file import Style
from video2style import pipeline


def learn(clip: Path, out: Path, iterations: int, whole: bool) -> dict:
    """One learn_file run; the stage times come from its progress lines' arrival."""
    stamps = []
    bound = pipeline.MAX_EXAMPLE_SECONDS
    if whole:
        pipeline.MAX_EXAMPLE_SECONDS = 1e9
    try:
        t0 = time.time()
        pipeline.learn_file(clip, out, text="a person walks", config=LearnConfig(iterations=iterations),
                            allow_partial=True, progress=lambda s: stamps.append((time.time() - t0, s.strip())))
        total = time.time() - t0
    finally:
        pipeline.MAX_EXAMPLE_SECONDS = bound
    at = {s.split(" ")[0] if not s.startswith("[") else s[:5]: t for t, s in stamps}
    pair = at.get("fine-tuning", total) - at.get("generating", 0.0)
    return {"total": total, "pair": pair, "iterations": total - at.get("fine-tuning", 0.0),
            "used": next((s for _, s in stamps if s.startswith("learning from")), "the whole input")}


def apply(style: Style, clip: Path, out: Path, capped: bool) -> float:
    from video2style.loaded_style import LoadedStyle

    loaded = LoadedStyle.from_style(style)
    real = pipeline.example_motion
    if not capped:
        pipeline.example_motion = lambda s, frames=None: real(s)
    try:
        t0 = time.time()
        loaded.apply(clip, out)
        return time.time() - t0
    finally:
        pipeline.example_motion = real


def choose_only(seconds: float, fps: float, out: Path) -> None:
    import resource

    clip = out / "take.bvh"
    write_bvh(clip, random_motion(seconds=seconds, fps=fps, seed=0, amplitude=0.3),
              BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    m = load_models()
    t0 = time.time()
    read = pipeline.read_clip(clip)
    t1 = time.time()
    part, used = pipeline.example_part(read.canonical, m.normalize(encode(read.canonical), inplace=True))
    t2 = time.time()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{seconds:g} s take at {fps:g} fps ({read.canonical.num_frames} frames at 20 fps): read {t1 - t0:.1f} s, "
          f"part chosen {t2 - t1:.1f} s ({used[0]:.0f}-{used[1]:.0f} s, {part.num_frames} frames); "
          f"peak memory {peak:.0f} MB")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=180.0)
    ap.add_argument("--iterations", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("/tmp/long_example"))
    ap.add_argument("--choose-only", action="store_true", help="only read a take and choose its part")
    ap.add_argument("--fps", type=float, default=20.0, help="--choose-only: the take's frame rate")
    args = ap.parse_args()
    torch.set_num_threads(2)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.choose_only:
        choose_only(args.seconds, args.fps, args.out)
        return
    layout = BvhLayout.default(CANONICAL.skeleton, scale=0.01)
    long_clip, short_clip = args.out / "long.bvh", args.out / "short.bvh"
    write_bvh(long_clip, random_motion(seconds=args.seconds, seed=1), layout)
    write_bvh(short_clip, random_motion(seconds=1.0, seed=2), layout)
    load_models()  # loaded once, outside the timings
    print(f"learn, {args.seconds:g} s input, {args.iterations} iterations (2-core CPU):")
    for whole in (False, True):
        r = learn(long_clip, args.out / f"style_{'whole' if whole else 'bounded'}.v2s", args.iterations, whole)
        print(f"  {'whole input (before)' if whole else 'bounded (now)':22s} pair {r['pair']:6.1f} s, "
              f"{args.iterations} iterations {r['iterations']:6.1f} s, in all {r['total']:6.1f} s; {r['used']}")
    style = Style.load(args.out / "style_bounded.v2s")
    style.example = encode(random_motion(seconds=args.seconds, seed=1))  # a style file learned before the bound
    print(f"apply to a 1 s clip, style example {args.seconds:g} s:")
    for capped in (True, False):
        seconds = apply(style, short_clip, args.out / ("capped" if capped else "uncapped"), capped)
        size = (args.out / ("capped" if capped else "uncapped") / "short_preview.mp4").stat().st_size
        print(f"  {'panel capped (now)' if capped else 'panel uncapped (before)':24s} {seconds:6.1f} s, "
              f"preview {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
