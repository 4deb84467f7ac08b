"""Training-step speed of denoiser sizes on this machine (why the prior is 4 x 256).

    python benchmarks/bench_denoiser_sizes.py [--threads 1] [--steps 5]

One step = forward + backward + Adam on a batch of 32 windows of 80 frames (the prior's
training shape), x0 loss at random diffusion steps with text conditioning.
"""
from __future__ import annotations

import argparse
import time

import torch

from motioncore.representation import FEATURES
from transfer.denoiser import Denoiser, DenoiserConfig

SIZES = {"Hu et al. 8x512 ff1024": (8, 512, 1024, 8), "6x384 ff768": (6, 384, 768, 6), "shipped 4x256 ff512": (4, 256, 512, 4)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--steps", type=int, default=5)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    x = torch.randn(32, 80, FEATURES.dim)
    text = torch.randn(32, 384)
    for name, (layers, width, ff, heads) in SIZES.items():
        model = Denoiser(DenoiserConfig(width=width, layers=layers, heads=heads, ff=ff))
        opt = torch.optim.Adam(model.parameters(), 1e-4)
        params = sum(p.numel() for p in model.parameters())
        times = []
        for _ in range(args.steps + 1):
            t0 = time.perf_counter()
            loss = ((model(x, torch.randint(1000, (32,)), text) - x) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            times.append(time.perf_counter() - t0)
        best = min(times[1:])
        print(f"{name:24s} {params / 1e6:5.2f} M params  {best:.2f} s/step (best of {args.steps})  {1 / best:.2f} steps/s")


if __name__ == "__main__":
    main()
