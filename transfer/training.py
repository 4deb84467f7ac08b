"""A small resumable training loop: time-bounded, seeded, progress bar, CSV log, safetensors checkpoints.

Checkpoints hold model weights, an EMA copy, the optimizer's moment tensors and the step, all as
safetensors (nothing is unpickled on resume). The run's config dataclass is stored in the
checkpoint; resuming with different explicit settings is an error, never a silent override.
"""
from __future__ import annotations

import copy
import csv
import json
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import torch
from safetensors import safe_open
from safetensors.torch import load_file, save_file
from tqdm import tqdm

from motioncore.files import atomic_output
from transfer.checkpoints import load_optimizer, optimizer_tensors


class Trainer:
    """Runs ``loss_fn(model, step) -> (loss tensor, dict of logged floats)`` until a step or time limit."""

    def __init__(self, model: torch.nn.Module, config, out_dir: Path, lr: float, warmup: int = 500, ema: float = 0.999, weight_decay: float = 0.0):
        self.model = model
        self.config = config
        self.out_dir = Path(out_dir)
        self.ema_decay = ema
        self.ema = copy.deepcopy(model).eval()
        for p in self.ema.parameters():
            p.requires_grad_(False)
        params = [p for p in model.parameters() if p.requires_grad]
        self.opt = torch.optim.AdamW(params, lr=lr, weight_decay=weight_decay)
        self.lr, self.warmup = lr, warmup
        self.names = {id(p): n for n, p in model.named_parameters()}
        self.step = 0
        self.elapsed = 0.0

    @property
    def checkpoint_path(self) -> Path:
        return self.out_dir / "checkpoint.safetensors"

    def save(self) -> None:
        self.out_dir.mkdir(parents=True, exist_ok=True)
        tensors = {f"model.{k}": v.detach().contiguous() for k, v in self.model.state_dict().items()}
        tensors.update({f"ema.{k}": v.detach().contiguous() for k, v in self.ema.state_dict().items()})
        tensors.update(optimizer_tensors(self.opt, self.names))
        meta = {"config": json.dumps(asdict(self.config)), "step": str(self.step), "elapsed": f"{self.elapsed:.1f}"}
        with atomic_output(self.checkpoint_path, ".tmp") as tmp:
            save_file(tensors, str(tmp), metadata=meta)

    def resume(self, explicit: dict) -> bool:
        """Load the checkpoint if present. ``explicit``: settings the user gave that must match it."""
        if not self.checkpoint_path.is_file():
            return False
        with safe_open(str(self.checkpoint_path), framework="pt") as f:
            meta = f.metadata()
        saved = json.loads(meta["config"])
        clash = {k: (saved.get(k), v) for k, v in explicit.items() if k in saved and saved[k] != v}
        if clash:
            detail = ", ".join(f"{k}: checkpoint {a!r} vs given {b!r}" for k, (a, b) in clash.items())
            raise ValueError(f"{self.checkpoint_path}: cannot resume with different settings ({detail}); use a new --out")
        tensors = load_file(str(self.checkpoint_path))
        self.model.load_state_dict({k[6:]: v for k, v in tensors.items() if k.startswith("model.")})
        self.ema.load_state_dict({k[4:]: v for k, v in tensors.items() if k.startswith("ema.")})
        load_optimizer(self.opt, self.names, tensors)
        self.step = int(meta["step"])
        self.elapsed = float(meta.get("elapsed", 0))
        return True

    @torch.no_grad()
    def _update_ema(self) -> None:
        d = min(self.ema_decay, (1 + self.step) / (10 + self.step))
        for pe, pm in zip(self.ema.parameters(), self.model.parameters()):
            pe.mul_(d).add_(pm.detach(), alpha=1 - d)
        for be, bm in zip(self.ema.buffers(), self.model.buffers()):
            be.copy_(bm)

    def run(self, loss_fn: Callable, max_steps: int, max_minutes: float, checkpoint_minutes: float = 5.0,
            progress: bool = True, evaluate: Callable | None = None, eval_every: int = 500) -> None:
        log_path = self.out_dir / "log.csv"
        self.out_dir.mkdir(parents=True, exist_ok=True)
        start = time.time()
        elapsed0 = self.elapsed
        last_ckpt = start
        bar = tqdm(total=max_steps, initial=self.step, disable=not progress, unit="step", dynamic_ncols=True)
        writer_file = open(log_path, "a", newline="")  # noqa: SIM115 - closed in the finally below
        writer = None
        try:
            self.model.train()
            while self.step < max_steps and (time.time() - start) < max_minutes * 60:
                loss, logs = loss_fn(self.model, self.step)
                for g in self.opt.param_groups:
                    g["lr"] = self.lr * min(1.0, (self.step + 1) / max(1, self.warmup))
                self.opt.zero_grad(set_to_none=True)
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.model.parameters(), 1.0)
                self.opt.step()
                self.step += 1
                self._update_ema()
                row = {"step": self.step, "time_s": round(elapsed0 + time.time() - start, 1), "loss": loss.item(), **logs}
                if evaluate is not None and self.step % eval_every == 0:
                    row.update(evaluate(self.ema, self.step))
                    self.model.train()
                if writer is None:
                    writer = csv.DictWriter(writer_file, fieldnames=list(row), extrasaction="ignore")
                    if log_path.stat().st_size == 0:
                        writer.writeheader()
                writer.writerow(row)
                bar.update(1)
                bar.set_postfix(loss=f"{row['loss']:.4f}")
                if time.time() - last_ckpt > checkpoint_minutes * 60:
                    writer_file.flush()
                    self.elapsed = elapsed0 + time.time() - start
                    self.save()
                    last_ckpt = time.time()
        finally:
            bar.close()
            writer_file.close()
            self.elapsed = elapsed0 + time.time() - start
            self.save()
