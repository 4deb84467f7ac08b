"""Time spans in seconds, ``(start, end)`` with None for an open end (torch-free: video code uses it too)."""

from __future__ import annotations

import math

Span = tuple[float | None, float | None]  # (start, end) in seconds; None = open end


def check_span(span: Span, source: str) -> Span:
    """``(start, end)`` in seconds, either None (open); raises ValueError naming ``source`` when invalid."""
    start, end = span
    for name, v in (("--start", start), ("--end", end)):
        if v is not None and not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{source}: {name} expected a time in seconds >= 0, got {v}")
    if start is not None and end is not None and end <= start:
        raise ValueError(f"{source}: --end ({end:g} s) must be after --start ({start:g} s)")
    return span


def frame_at(seconds: float, fps: float, frames: int) -> int:
    """The first of ``frames`` frames (at ``fps``) at or after ``seconds``, ``frames`` when none is: a time far past
    the end (``1e308``, whose frame number overflows) is the end."""
    x = seconds * fps - 1e-6
    return frames if not x < frames else max(0, math.ceil(x))
