"""Where one style-learning iteration spends its time, and seconds per iteration.

    python benchmarks/profile_learn.py [--iterations 20] [--threads 2] [--data DIR]

The example is a 10 s prior sample of "a person walks, elderly style" (project-made); content clips come
from the dataset cache (``--data``, default the user cache) or the bundled content bank. The breakdown
uses the ``record_function`` labels inside :func:`transfer.learn.learn_style` (pair generation happens
once per style, outside the iterations). Run it on a quiet machine; the shares hold under load too.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

import torch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--iterations", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)

    from motioncore.representation import encode
    from transfer.bundle import load_models
    from transfer.learn import learn_style
    from transfer.style_config import LearnConfig
    from video2style.pipeline import content_source, prior_samples

    m = load_models()
    example = m.normalize(encode(prior_samples(["a person walks, elderly style"], frames=200, seed=1)[0]))
    data = content_source(progress=lambda s: None)
    config = replace(LearnConfig(), iterations=args.iterations)
    t0 = time.perf_counter()
    with torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU]) as prof:
        learn_style(m, data, example, "elderly", "walk", config)
    total = time.perf_counter() - t0
    labels = {e.key: e.cpu_time_total / 1e6 for e in prof.key_averages() if e.key.startswith("learn: ")}
    print(f"learn_style, {args.iterations} iterations, {args.threads} threads: {total:.1f} s in all "
          f"(profiler on; it adds a little)")
    inner = sum(labels.values())
    for key, sec in sorted(labels.items(), key=lambda kv: -kv[1]):
        print(f"  {key[7:]:22s} {1000 * sec / args.iterations:7.1f} ms / iteration  ({100 * sec / inner:4.1f} %)")
    print(f"  {'all labelled':22s} {1000 * inner / args.iterations:7.1f} ms / iteration")
    t0 = time.perf_counter()
    learn_style(m, data, example, "elderly", "walk", replace(config, iterations=1))
    one = time.perf_counter() - t0
    t0 = time.perf_counter()
    learn_style(m, data, example, "elderly", "walk", config)
    many = time.perf_counter() - t0
    per_it = (many - one) / (args.iterations - 1)
    print(f"without the profiler: {per_it:.3f} s / iteration, {one - per_it:.1f} s fixed (neutral pair, model copy); "
          f"{LearnConfig.iterations} iterations (the default) -> {one - per_it + LearnConfig.iterations * per_it:.0f} s")


if __name__ == "__main__":
    main()
