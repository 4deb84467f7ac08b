"""Cost of one training step of the prior on this machine, per precision (issue 24: cheaper steps).

    OMP_NUM_THREADS=1 python benchmarks/prior_step_cost.py [--modes fp32 bf16 compile] [--steps 30] [--rounds 3]

Each mode trains its own copy of the shipped-size denoiser (transfer.prior.PriorTrainConfig sizes) on random
batches with :func:`transfer.prior.diffusion_loss`; the modes take turns in rounds, so a busy machine slows them
alike and the printed ratios to fp32 hold. ``compile`` is fp32 under ``torch.compile`` (its compile time is
printed apart).
"""
from __future__ import annotations

import argparse
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--modes", nargs="+", default=["fp32", "bf16"], choices=["fp32", "bf16", "compile"])
    ap.add_argument("--steps", type=int, default=30, help="timed steps per mode and round")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()

    import torch

    from transfer.denoiser import Denoiser, DenoiserConfig
    from transfer.prior import PriorTrainConfig, diffusion_loss
    from transfer.scheduler import DiffusionScheduler

    cfg = PriorTrainConfig()
    scheduler = DiffusionScheduler()
    runs = {}
    for mode in args.modes:
        torch.manual_seed(0)
        model = Denoiser(DenoiserConfig(width=cfg.width, layers=cfg.layers, heads=cfg.heads, ff=cfg.ff)).train()
        opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr)
        runs[mode] = (torch.compile(model) if mode == "compile" else model, opt, "fp32" if mode == "compile" else mode)
    gen = torch.Generator().manual_seed(0)
    dim = DenoiserConfig().feature_dim

    def step(mode: str) -> None:
        model, opt, precision = runs[mode]
        b, w = cfg.batch_size, cfg.window
        x0, valid = torch.randn(b, w, dim, generator=gen), torch.ones(b, w, dtype=torch.bool)
        text, drop = torch.randn(b, 384, generator=gen), torch.zeros(b, dtype=torch.bool)
        loss, _ = diffusion_loss(model, scheduler, x0, valid, text, drop, cfg.velocity_weight, gen, precision)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    for mode in args.modes:  # warm-up (and compile)
        t0 = time.perf_counter()
        for _ in range(3):
            step(mode)
        print(f"{mode}: warm-up {time.perf_counter() - t0:.1f} s")
    spent = dict.fromkeys(args.modes, 0.0)
    for _ in range(args.rounds):
        for mode in args.modes:
            t0 = time.perf_counter()
            for _ in range(args.steps):
                step(mode)
            spent[mode] += time.perf_counter() - t0
    n = args.steps * args.rounds
    base = spent[args.modes[0]]
    for mode in args.modes:
        print(f"{mode:>8}: {n / spent[mode]:.2f} steps/s, {base / spent[mode]:.2f}x {args.modes[0]} "
              f"(batch {cfg.batch_size} x {cfg.window} frames, {torch.get_num_threads()} threads)")


if __name__ == "__main__":
    main()
