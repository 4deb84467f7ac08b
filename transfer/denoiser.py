"""MDM-style denoiser: (noisy motion, step, text embedding) -> predicted clean motion x0."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
from safetensors.torch import load_file
from torch import nn

from motioncore.representation import FEATURES
from transfer.checkpoints import load_config
from transfer.layers import Block, MotionEmbedding, sinusoidal


@dataclass
class DenoiserConfig:
    feature_dim: int = FEATURES.dim
    text_dim: int = 384
    width: int = 256
    layers: int = 4
    heads: int = 4
    ff: int = 512
    dropout: float = 0.1
    num_train_steps: int = 1000


class Denoiser(nn.Module):
    """``forward(x_t (B, T, D), t (B,), text (B, E) | None, valid (B, T) | None) -> x0 (B, T, D)``.

    The step and text embeddings are summed into one condition token placed before the motion
    tokens. ``text=None`` (or rows of ``drop`` set True) is the unconditional model used for
    classifier-free guidance.
    """

    def __init__(self, config: DenoiserConfig):
        super().__init__()
        self.config = c = config
        self.embed = MotionEmbedding(c.feature_dim, c.width)
        self.time_mlp = nn.Sequential(nn.Linear(c.width, c.width), nn.SiLU(), nn.Linear(c.width, c.width))
        self.text_proj = nn.Linear(c.text_dim, c.width)
        self.blocks = nn.ModuleList([Block(c.width, c.heads, c.ff, c.dropout) for _ in range(c.layers)])
        self.norm = nn.LayerNorm(c.width)
        self.out = nn.Linear(c.width, c.feature_dim)

    def forward(self, x_t, t, text=None, valid=None, drop=None):
        b, _, d = x_t.shape
        if d != self.config.feature_dim:
            raise ValueError(f"Denoiser: expected x_t (B, T, {self.config.feature_dim}), got {tuple(x_t.shape)}")
        cond = self.time_mlp(sinusoidal(torch.as_tensor(t, device=x_t.device).expand(b), self.config.width))
        if text is not None:
            txt = self.text_proj(text)
            if drop is not None:
                txt = txt * (~drop)[:, None].to(txt.dtype)
            cond = cond + txt
        h = torch.cat([cond[:, None], self.embed(x_t, offset=1)], dim=1)
        full_valid = None
        if valid is not None:
            full_valid = torch.cat([torch.ones(b, 1, dtype=torch.bool, device=x_t.device), valid], dim=1)
        for blk in self.blocks:
            h = blk(h, full_valid)
        return self.out(self.norm(h[:, 1:]))


def load_denoiser(path: Path) -> tuple[Denoiser, dict[str, torch.Tensor]]:
    """Load a denoiser; returns the model and any extra tensors (e.g. normalisation stats)."""
    config = load_config(path, DenoiserConfig)
    model = Denoiser(config)
    tensors = load_file(str(path))
    own = set(model.state_dict())
    model.load_state_dict({k: v for k, v in tensors.items() if k in own})
    return model.eval(), {k: v for k, v in tensors.items() if k not in own}
