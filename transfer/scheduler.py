"""Gaussian diffusion noise schedule and samplers. No model imports.

The model predicts x0. ``step`` moves a sample from step ``t`` to the previous step of the
schedule set by ``set_timesteps``; DDIM with ``eta=0`` is deterministic, ``eta=1`` is DDPM-like.
"""
from __future__ import annotations

import math

import torch


class DiffusionScheduler:
    """A cosine schedule over ``num_train_steps`` (1000 by default)."""

    def __init__(self, num_train_steps: int = 1000):
        self.num_train_steps = num_train_steps
        s = 0.008
        t = torch.arange(num_train_steps + 1, dtype=torch.float64) / num_train_steps
        f = torch.cos((t + s) / (1 + s) * math.pi / 2) ** 2
        alphas_cumprod = (f[1:] / f[0]).clamp(1e-9, 1.0)
        self.alphas_cumprod = alphas_cumprod.float()  # index t = 0 .. N-1 (t = 0: least noise)
        self._tables = {self.alphas_cumprod.device: self.alphas_cumprod}  # the table on each device used
        self.timesteps = torch.arange(num_train_steps - 1, -1, -1)

    def set_timesteps(self, num_steps: int, start: int | None = None) -> torch.Tensor:
        """Evenly spaced steps from ``start`` (default: the last, pure noise) down to 0."""
        start = self.num_train_steps - 1 if start is None else int(start)
        if not 0 <= start < self.num_train_steps or num_steps < 1:
            raise ValueError(f"set_timesteps: expected 1 <= num_steps and 0 <= start < {self.num_train_steps}, got {num_steps}, {start}")
        steps = torch.linspace(start, 0, min(num_steps, start + 1)).round().long()
        self.timesteps = torch.unique_consecutive(steps)
        return self.timesteps

    def add_noise(self, x0: torch.Tensor, noise: torch.Tensor, t: torch.Tensor | int) -> torch.Tensor:
        """``q(x_t | x0)`` for ``x0 (B, T, D)`` and ``t`` an int or ``(B,)``."""
        a = self.alpha(t, x0)
        return a.sqrt() * x0 + (1 - a).sqrt() * noise

    def alpha(self, t: torch.Tensor | int, like: torch.Tensor) -> torch.Tensor:
        """``alphas_cumprod[t]`` on ``like``'s device: a scalar tensor for an int ``t``, ``(B, 1, ...)`` for
        ``t (B,)``, shaped to broadcast over ``like (B, ...)``."""
        table = self._table(like.device)
        if isinstance(t, int):  # a plain index: no index tensor (on a GPU, no round trip to read it back)
            return table[t]
        a = table[torch.as_tensor(t, device=like.device).long()]
        return a.reshape(-1, *([1] * (like.ndim - 1))) if a.ndim else a

    def _table(self, device: torch.device) -> torch.Tensor:
        """``alphas_cumprod`` on ``device``, copied there once."""
        if device not in self._tables:
            self._tables[device] = self.alphas_cumprod.to(device)
        return self._tables[device]

    def previous(self, t: int) -> int:
        """The step after ``t`` in the current schedule, or -1 at the end."""
        idx = (self.timesteps == t).nonzero()
        if idx.numel() == 0 or idx.item() + 1 >= len(self.timesteps):
            return -1
        return int(self.timesteps[idx.item() + 1])

    def step(self, x0_pred: torch.Tensor, t: int, x_t: torch.Tensor, eta: float = 0.0, generator: torch.Generator | None = None) -> torch.Tensor:
        """One DDIM step from ``x_t`` (step ``t``) given the model's ``x0_pred``; returns x at the previous step.
        Noise (``eta > 0``) is drawn on the CPU from ``generator`` and moved to ``x_t``'s device."""
        prev = self.previous(t)
        if prev < 0:
            return x0_pred
        a_t, a_prev = self.alpha(t, x_t), self.alpha(prev, x_t)
        eps = (x_t - a_t.sqrt() * x0_pred) / (1 - a_t).sqrt()
        sigma = eta * ((1 - a_prev) / (1 - a_t) * (1 - a_t / a_prev)).clamp_min(0).sqrt()
        direction = (1 - a_prev - sigma**2).clamp_min(0).sqrt() * eps
        x_prev = a_prev.sqrt() * x0_pred + direction
        if eta > 0:
            x_prev = x_prev + sigma * torch.randn(x_t.shape, generator=generator, dtype=x_t.dtype).to(x_t.device)
        return x_prev
