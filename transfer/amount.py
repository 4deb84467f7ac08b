"""How much of a style to apply: as much as its example shows.

One strength for every style is the wrong unit: a style model learned from one example carries more or less of
it to other actions, and a user asks for "this style as the example shows it". So learning measures how far the
example stands from its neutral pair (:func:`style_distance`, over the body channels' time statistics, which do
not depend on the action), applies the fresh style at gain 1 to a few neutral clips of other actions
(:data:`CALIBRATION_CONTENTS`), and records the gain that makes results differ from their content about as much
(:func:`calibrate_gain`, within :data:`GAIN_RANGE`). ``apply`` multiplies the style's change (and its posture)
by it; ``--strength`` stays the user's scale around it (0.5: the calibrated amount). The content keeper still
scales a result back where the action would be lost.
"""
from __future__ import annotations

import statistics

import torch

from transfer.style_config import style_amount
from transfer.style_losses import time_stats

GAIN_RANGE = (0.5, 3.0)  # the calibrated gain stays within these (a style model that barely moves is not blown up)
CALIBRATION_CONTENTS = ("walk", "walk-turn-left", "walk-turn-right", "run", "raise-up-both-hands", "wave-both-hands")
CALIBRATION_FRAMES = 80  # the first window of each calibration clip


def style_distance(a: torch.Tensor, b: torch.Tensor) -> float:
    """How far normalised motion ``a (T, D)`` stands from ``b (T', D)`` in what does not depend on the action:
    the root-mean-square change over the body channels (:data:`transfer.style_losses.STAT_CHANNELS`) of their
    time-means and log standard deviations (:func:`transfer.style_losses.time_stats`), one number."""
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[1]:
        raise ValueError(f"style_distance: expected two motions (T, D), got {tuple(a.shape)} and {tuple(b.shape)}")
    (m_a, s_a), (m_b, s_b) = time_stats(a[None].float()), time_stats(b[None].float())
    return float(torch.cat([m_a - m_b, s_a - s_b], -1).pow(2).mean().sqrt())


def calibration_clips(dataset, frames: int = CALIBRATION_FRAMES) -> list[torch.Tensor]:
    """The first neutral ('normal') clip of each of :data:`CALIBRATION_CONTENTS` in ``dataset`` (the content source
    learning uses: the dataset cache or the shipped bank), its first ``frames`` frames, normalised ``(T, D)``."""
    clips = []
    for content in CALIBRATION_CONTENTS:
        for i, r in enumerate(dataset.records):
            if r.style == "normal" and r.content == content and not getattr(r, "mirrored", False):
                clips.append(dataset.clip(i)[:frames])
                break
    return clips


def calibrate_gain(apply_fn, target: float, clips: list[torch.Tensor]) -> tuple[float, float]:
    """``(gain, reached)``: the gain within :data:`GAIN_RANGE` that brings the median :func:`style_distance` of
    ``apply_fn(clip) (T, D)`` (a style applied at gain 1) from each clip to ``target`` (the example's from its
    pair), taking the distance as proportional to the gain; ``reached`` is that median at gain 1. No clips, or a
    style that does not move them: gain 1."""
    if not clips or target <= 0:
        return 1.0, 0.0
    reached = statistics.median(style_distance(apply_fn(c), c) for c in clips)
    if reached <= 1e-6:
        return 1.0, reached
    low, high = GAIN_RANGE
    return min(high, max(low, target / reached)), reached


def describe_amount(gain: float, target: float, reached: float | None) -> str:
    """The one plain line ``learn`` prints about how strongly the style will show: the example's distance from its
    neutral pair (``target``, :func:`style_distance`) and how many times ``--strength 0.5`` applies the learned change
    (:func:`transfer.style_config.style_amount`); with a calibration (``reached``: the learned change's distance on
    other actions at gain 1; None: not calibrated, ``gain`` 1) how far that carries."""
    times = style_amount(0.5, gain)
    if reached is None:
        return (f"style amount: the example differs from its neutral version by {target:.2f}; --strength 0.5 applies "
                f"the learned change {times:.1f}x, 1 applies it {2 * times:.1f}x (learn --calibrate fits it to the example)")
    if reached <= 0:
        return (f"style amount: not calibrated (no neutral clips to measure on); --strength 0.5 applies the learned "
                f"change {times:.1f}x")
    where = ("as much as the example shows" if GAIN_RANGE[0] < gain < GAIN_RANGE[1] else
             f"held at {gain:.1f}x, the {'most' if gain >= GAIN_RANGE[1] else 'least'} the tool applies")
    return (f"style amount: the example differs from its neutral version by {target:.2f}; the learned change alone "
            f"moves other actions {reached:.2f}, so --strength 0.5 applies it {times:.1f}x ({where})")
