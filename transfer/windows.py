"""Long motions in overlapping windows: where windows start, and blending their results back (no model
import: both the diffusion method and Park et al.'s stylizer use them)."""
from __future__ import annotations

from collections.abc import Iterable

import torch


def crossfade_overlap(window: int) -> int:
    """Frames two neighbouring windows of ``window`` frames share when a long motion is drawn or stylised in
    them: a quarter of one (20 of the prior's 80; learning's neutral pair and ``apply`` alike)."""
    return window // 4


def window_starts(n: int, window: int, overlap: int) -> list[int]:
    """Starts of windows covering ``n`` frames; the last window ends at ``n``."""
    if n <= window:
        return [0]
    hop = window - overlap
    starts = list(range(0, n - window, hop))
    return starts + [n - window]


def crossfade(chunks: Iterable[torch.Tensor], starts: list[int], n: int) -> torch.Tensor:
    """Blend overlapping windows ``(L, D)`` into ``(n, D)`` with linear ramps over the overlaps (on the windows'
    device). ``chunks`` may be a generator: each window is added as it comes and not kept, so a long clip holds
    the blend and the windows being made, not every window's result."""
    out = total = None
    prev_end = 0  # windows come in order of their starts
    for chunk, s in zip(chunks, starts):
        if out is None:
            device = chunk.device
            out = torch.zeros(n, chunk.shape[-1], device=device)
            total = torch.zeros(n, 1, device=device)
        length = chunk.shape[0]
        w = torch.ones(length, device=device)
        if s > 0:  # ramp in over the overlap with the previous window
            ramp = max(1, prev_end - s)
            w[:ramp] = torch.linspace(0, 1, ramp + 2, device=device)[1:-1]
        out[s:s + length] += chunk * w[:, None]
        total[s:s + length] += w[:, None]
        prev_end = max(prev_end, s + length)
    if out is None:
        raise ValueError(f"crossfade: expected at least one window, got none for {n} frames")
    return out.div_(total.clamp_min_(1e-6))  # in place: no second (n, D) copy


def typical_window(x: torch.Tensor, length: int, hop: int) -> int:
    """Start of the ``length``-frame window of ``x (T, D)`` whose per-feature means and standard deviations are
    nearest those of the typical window (the median of each over all windows): the most typical part of a long
    style example, among starts every ``hop`` frames;
    0 when ``T <= length``. Statistics come from ``hop``-frame blocks, so memory is ``T / hop`` rows, not ``T``."""
    if x.ndim != 2:
        raise ValueError(f"typical_window: expected features (T, D), got {tuple(x.shape)}")
    if not 0 < hop <= length:
        raise ValueError(f"typical_window: expected 0 < hop <= length, got hop {hop}, length {length}")
    n = x.shape[0]
    if n <= length:
        return 0
    blocks = n // hop
    s1 = torch.zeros(blocks + 1, x.shape[1], dtype=torch.float64)
    s2 = torch.zeros_like(s1)
    for a in range(0, blocks, 4096):  # block sums, a bounded slice of x at a time
        b = min(a + 4096, blocks)
        part = x[a * hop:b * hop].double().reshape(b - a, hop, -1)
        s1[a + 1:b + 1], s2[a + 1:b + 1] = part.sum(1), (part ** 2).sum(1)
    s1, s2 = s1.cumsum(0), s2.cumsum(0)
    k = length // hop  # a window: k blocks
    starts = torch.arange(0, blocks - k + 1)
    mean = (s1[starts + k] - s1[starts]) / (k * hop)
    std = ((s2[starts + k] - s2[starts]) / (k * hop) - mean ** 2).clamp_min(0).sqrt()
    # the centre: each statistic's median over the windows, so an odd stretch (walking into the frame) moves it
    # little, where the whole clip's mean would favour windows that mix the odd stretch in
    score = ((mean - mean.median(0).values) ** 2).sum(1) + ((std - std.median(0).values) ** 2).sum(1)
    return int(starts[score.argmin()]) * hop
