"""Long motions in overlapping windows: where windows start, and blending their results back (no model
import: both the diffusion method and Park et al.'s stylizer use them)."""
from __future__ import annotations

import torch


def window_starts(n: int, window: int, overlap: int) -> list[int]:
    """Starts of windows covering ``n`` frames; the last window ends at ``n``."""
    if n <= window:
        return [0]
    hop = window - overlap
    starts = list(range(0, n - window, hop))
    return starts + [n - window]


def crossfade(chunks: list[torch.Tensor], starts: list[int], n: int) -> torch.Tensor:
    """Blend overlapping windows ``(L, D)`` into ``(n, D)`` with linear ramps over the overlaps (on the windows'
    device)."""
    device = chunks[0].device
    out = torch.zeros(n, chunks[0].shape[-1], device=device)
    total = torch.zeros(n, 1, device=device)
    prev_end = 0  # windows come in order of their starts
    for chunk, s in zip(chunks, starts):
        length = chunk.shape[0]
        w = torch.ones(length, device=device)
        if s > 0:  # ramp in over the overlap with the previous window
            ramp = max(1, prev_end - s)
            w[:ramp] = torch.linspace(0, 1, ramp + 2, device=device)[1:-1]
        out[s:s + length] += chunk * w[:, None]
        total[s:s + length] += w[:, None]
        prev_end = max(prev_end, s + length)
    return out / total.clamp_min(1e-6)
