"""One resumable training loop for every trainer: step- and time-bounded, seeded, progress bar, CSV log,
periodic safetensors checkpoints (:class:`mlcore.checkpoints.RunCheckpoint`).

:class:`Trainer` runs it for one model with one AdamW optimizer and an EMA copy (prior, motion encoder,
classifiers); Park et al.'s GAN (:mod:`park.train`) runs the same loop with its own iteration.
"""
from __future__ import annotations

import copy
import csv
import time
from collections.abc import Callable
from pathlib import Path

import torch
from tqdm import tqdm

from mlcore.checkpoints import RunCheckpoint


@torch.no_grad()
def update_ema(ema: torch.nn.Module, model: torch.nn.Module, decay: float, step: int) -> None:
    """``ema <- d * ema + (1 - d) * model`` with ``d = min(decay, (1 + step) / (10 + step))``; buffers copied."""
    d = min(decay, (1 + step) / (10 + step))
    for pe, pm in zip(ema.parameters(), model.parameters()):
        pe.mul_(d).add_(pm.detach(), alpha=1 - d)
    for be, bm in zip(ema.buffers(), model.buffers()):
        be.copy_(bm)


def train_loop(checkpoint: RunCheckpoint, iterate: Callable[[], dict], log_path: Path, max_steps: int,
               max_minutes: float, checkpoint_minutes: float = 5.0, progress: bool = True,
               fields: list[str] | None = None, postfix: Callable[[dict], dict] | None = None) -> None:
    """Call ``iterate()`` (one training step: it advances ``checkpoint.step`` and returns the row to log)
    until ``max_steps`` or ``max_minutes`` of this call; append each row to ``log_path`` (columns
    ``fields``, else the first row's); save the checkpoint every ``checkpoint_minutes`` and at the end."""
    log_path = Path(log_path)
    log_path.parent.mkdir(parents=True, exist_ok=True)
    start = last_ckpt = time.time()
    elapsed0 = checkpoint.elapsed
    # no step budget (the default 10**9): a count and a rate, not an ETA of a hundred thousand hours
    bar = tqdm(total=max_steps if max_steps < 10**9 else None, initial=checkpoint.step, disable=not progress,
               unit="step", dynamic_ncols=True)
    writer_file = open(log_path, "a", newline="")  # noqa: SIM115 - closed in the finally below
    writer = None
    try:
        while checkpoint.step < max_steps and (time.time() - start) < max_minutes * 60:
            row = {"step": None, "time_s": None, **iterate()}
            row.update(step=checkpoint.step, time_s=round(elapsed0 + time.time() - start, 1))
            if writer is None:
                names = fields or list(row)
                if log_path.stat().st_size > 0:  # a resumed run: keep the file's columns, add any new ones
                    writer_file.close()
                    names = _widen_log(log_path, names)
                    writer_file = open(log_path, "a", newline="")  # noqa: SIM115 - closed in the finally below
                writer = csv.DictWriter(writer_file, fieldnames=names, extrasaction="ignore")
                if log_path.stat().st_size == 0:
                    writer.writeheader()
            writer.writerow(row)
            bar.update(1)
            bar.set_postfix(postfix(row) if postfix is not None else {})
            if time.time() - last_ckpt > checkpoint_minutes * 60:
                writer_file.flush()
                checkpoint.elapsed = elapsed0 + time.time() - start
                checkpoint.save()
                last_ckpt = time.time()
    finally:
        bar.close()
        writer_file.close()
        checkpoint.elapsed = elapsed0 + time.time() - start
        checkpoint.save()


def _widen_log(path: Path, names: list[str]) -> list[str]:
    """The columns a resumed run appends to the CSV log at ``path``: the file's own, then any of ``names`` it
    lacks (a new stage logs a new loss term); the file is rewritten with the wider header when there are new
    ones, its earlier rows left blank in them."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0] if rows else []
    new = [n for n in names if n not in header]
    if new and header:
        from motioncore.files import atomic_write_text

        lines = [",".join(header + new)] + [",".join(r + [""] * len(new)) for r in rows[1:]]
        atomic_write_text(path, "\n".join(lines) + "\n")
    return header + new if header else names


def lr_factor(step: int, warmup: int, decay_start: int = 0, decay_steps: int = 0, final: float = 1.0) -> float:
    """The learning rate's multiplier at ``step`` (0-based): linear warmup over ``warmup`` steps, constant, then
    (when ``decay_steps`` > 0) a linear fall from 1 at ``decay_start`` to ``final`` at ``decay_start + decay_steps``,
    ``final`` after (warmup-stable-decay)."""
    factor = min(1.0, (step + 1) / max(1, warmup))
    if decay_steps > 0 and step >= decay_start:
        done = min(1.0, (step - decay_start) / decay_steps)
        factor *= 1.0 - (1.0 - final) * done
    return factor


class Trainer:
    """Runs ``loss_fn(model, step) -> (loss tensor, dict of logged floats)`` with AdamW (:func:`lr_factor`'s
    schedule, gradients clipped to norm 1) and an EMA copy, until a step or time limit. ``trainer.step``: steps
    done. ``decay``: ``(decay_start, decay_steps, final)`` for :func:`lr_factor`, None for a constant rate."""

    def __init__(self, model: torch.nn.Module, config, out_dir: Path, lr: float, warmup: int = 500, ema: float = 0.999,
                 weight_decay: float = 0.0, decay: tuple[int, int, float] | None = None):
        self.model = model
        self.config = config
        self.out_dir = Path(out_dir)
        self.ema_decay = ema
        self.ema = copy.deepcopy(model).eval()
        for p in self.ema.parameters():
            p.requires_grad_(False)
        params = [p for p in model.parameters() if p.requires_grad]
        self.opt = torch.optim.AdamW(params, lr=lr, weight_decay=weight_decay)
        self.lr, self.warmup, self.decay = lr, warmup, decay or (0, 0, 1.0)
        names = {id(p): n for n, p in model.named_parameters()}
        self.checkpoint = RunCheckpoint(self.out_dir / "checkpoint.safetensors", config,
                                        {"model": model, "ema": self.ema}, {"": self.opt}, names)

    @property
    def step(self) -> int:
        return self.checkpoint.step

    @property
    def elapsed(self) -> float:
        """Seconds trained over all sessions of the run."""
        return self.checkpoint.elapsed

    @property
    def checkpoint_path(self) -> Path:
        return self.checkpoint.path

    def save(self) -> None:
        self.checkpoint.save()

    def resume(self, explicit: dict) -> bool:
        """Load the checkpoint if present. ``explicit``: settings the user gave that must match it."""
        return self.checkpoint.resume(explicit)

    def run(self, loss_fn: Callable, max_steps: int, max_minutes: float, checkpoint_minutes: float = 5.0,
            progress: bool = True, evaluate: Callable | None = None, eval_every: int = 500) -> None:
        def iterate() -> dict:
            loss, logs = loss_fn(self.model, self.step)
            for g in self.opt.param_groups:
                g["lr"] = self.lr * lr_factor(self.step, self.warmup, *self.decay)
            self.opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(self.model.parameters(), 1.0)
            self.opt.step()
            self.checkpoint.step += 1
            update_ema(self.ema, self.model, self.ema_decay, self.step)
            row = {"loss": loss.item(), **logs}
            if evaluate is not None and self.step % eval_every == 0:
                row.update(evaluate(self.ema, self.step))
                self.model.train()
            return row

        self.model.train()
        train_loop(self.checkpoint, iterate, self.out_dir / "log.csv", max_steps, max_minutes, checkpoint_minutes,
                   progress, postfix=lambda row: {"loss": f"{row['loss']:.4f}"})
