"""Long motions in overlapping windows: where windows start, and blending their results back (no model
import: both the diffusion method and Park et al.'s stylizer use them)."""
from __future__ import annotations

from collections.abc import Callable, Iterable

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


class WindowStream:
    """The windows of a motion of ``n`` frames (:func:`window_starts`), run on its features fed in order, a span at
    a time or all at once: ``feed(x)`` takes the next frames ``(k, D)`` and returns the frames now finished (every
    window over them blended as :func:`crossfade` blends them; fed whole, the same tensor). ``fn(windows (B, L, D),
    i)`` gives the results of windows ``i..i+B-1``, ``batch`` at a time from the first, so noise drawn in order from
    one generator is the same noise however the motion is fed; the windows are views of the frames fed (copied
    only when a batch is made), so a long motion's windows are never all in memory at once."""

    def __init__(self, fn: Callable[[torch.Tensor, int], Iterable[torch.Tensor]], n: int, batch: int,
                 window: int = 80, overlap: int = 20):
        self.fn, self.n, self.batch = fn, n, batch
        self.starts = window_starts(n, window, overlap)
        self.length = min(window, n)
        self.inbuf, self.in0 = None, 0  # input frames from in0 on
        self.acc, self.tot, self.out0 = None, None, 0  # blend of frames out0.. (not yet finished)
        self.i, self.prev_end = 0, 0

    def feed(self, x: torch.Tensor) -> torch.Tensor:
        self.inbuf = x if self.inbuf is None else torch.cat([self.inbuf, x])
        in_end = self.in0 + self.inbuf.shape[0]
        self._grow(x, in_end - self.out0)  # once per feed: no window added now ends past in_end
        view = self.inbuf.unfold(0, self.length, 1) if self.inbuf.shape[0] >= self.length else None  # (k, D, L)
        while self.i < len(self.starts):
            j = min(self.i + self.batch, len(self.starts))
            if self.starts[j - 1] + self.length > in_end:
                break
            starts = self.starts[self.i:j]
            part = view[[s - self.in0 for s in starts]].transpose(1, 2)
            for chunk, s in zip(self.fn(part, self.i), starts):
                self._add(chunk, s)
            self.i = j
        done = self.starts[self.i] if self.i < len(self.starts) else self.n
        if self.i < len(self.starts):  # the inputs before the next window are no longer needed
            self.inbuf, self.in0 = self.inbuf[done - self.in0:], done
        if done <= self.out0:
            return x.new_zeros(0, x.shape[1])
        k = done - self.out0
        out = self.acc[:k].div_(self.tot[:k].clamp_min_(1e-6))  # in place: no second copy of the blend
        self.acc, self.tot, self.out0 = self.acc[k:], self.tot[k:], done
        return out

    def _grow(self, x: torch.Tensor, rows: int) -> None:
        """The blend holds at least ``rows`` frames from out0 on (new frames: zero)."""
        if self.acc is None:  # float32 on the frames' device, as crossfade's
            self.acc, self.tot = torch.zeros(rows, x.shape[-1], device=x.device), torch.zeros(rows, 1, device=x.device)
        elif rows > self.acc.shape[0]:
            grow = rows - self.acc.shape[0]
            self.acc = torch.cat([self.acc, torch.zeros(grow, x.shape[-1], device=x.device)])
            self.tot = torch.cat([self.tot, torch.zeros(grow, 1, device=x.device)])

    def _add(self, chunk: torch.Tensor, s: int) -> None:
        length = chunk.shape[0]
        w = torch.ones(length, device=chunk.device)
        if s > 0:  # ramp in over the overlap with the previous window (as crossfade)
            ramp = max(1, self.prev_end - s)
            w[:ramp] = torch.linspace(0, 1, ramp + 2, device=chunk.device)[1:-1]
        a = s - self.out0
        self.acc[a:a + length] += chunk * w[:, None]
        self.tot[a:a + length] += w[:, None]
        self.prev_end = max(self.prev_end, s + length)


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
