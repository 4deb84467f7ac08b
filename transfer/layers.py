"""Transformer blocks shared by the denoiser and the motion encoder.

Attention and feed-forward projections are plain ``nn.Linear`` so adapters (LoRA) can wrap them.
"""
from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F


def sinusoidal(positions: torch.Tensor, dim: int) -> torch.Tensor:
    """``positions (*)`` -> ``(*, dim)`` sinusoidal features."""
    half = dim // 2
    freqs = torch.exp(-math.log(10000.0) * torch.arange(half, dtype=torch.float32, device=positions.device) / half)
    ang = positions.float()[..., None] * freqs
    return torch.cat([torch.sin(ang), torch.cos(ang)], dim=-1)


class Block(nn.Module):
    """Pre-norm transformer encoder block over ``(B, N, W)`` with a key padding mask ``(B, N)`` (True = valid)."""

    def __init__(self, width: int, heads: int, ff: int, dropout: float):
        super().__init__()
        if width % heads:
            raise ValueError(f"Block: expected width divisible by heads, got {width} and {heads}")
        self.heads = heads
        self.norm1 = nn.LayerNorm(width)
        self.q = nn.Linear(width, width)
        self.k = nn.Linear(width, width)
        self.v = nn.Linear(width, width)
        self.o = nn.Linear(width, width)
        self.norm2 = nn.LayerNorm(width)
        self.ff1 = nn.Linear(width, ff)
        self.ff2 = nn.Linear(ff, width)
        self.dropout = nn.Dropout(dropout)

    def forward(self, h: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        b, n, w = h.shape
        x = self.norm1(h)
        q, k, v = (proj(x).view(b, n, self.heads, w // self.heads).transpose(1, 2) for proj in (self.q, self.k, self.v))
        bias = None if valid is None else valid[:, None, None, :]
        a = F.scaled_dot_product_attention(q, k, v, attn_mask=bias, dropout_p=self.dropout.p if self.training else 0.0)
        h = h + self.dropout(self.o(a.transpose(1, 2).reshape(b, n, w)))
        return h + self.dropout(self.ff2(self.dropout(F.gelu(self.ff1(self.norm2(h))))))


class MotionEmbedding(nn.Module):
    """Features ``(B, T, D)`` -> tokens ``(B, T, W)`` with positions added."""

    def __init__(self, feature_dim: int, width: int):
        super().__init__()
        self.proj = nn.Linear(feature_dim, width)
        self.width = width

    def forward(self, x: torch.Tensor, offset: int = 0) -> torch.Tensor:
        pos = torch.arange(x.shape[1], device=x.device) + offset
        return self.proj(x) + sinusoidal(pos, self.width)
