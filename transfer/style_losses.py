"""Style signals that need no style words: what the example changes against its neutral pair, asked of the
content batch while a style learns (see :func:`transfer.learn.learn_style`).

- :func:`statistics_loss`: the change the style model makes to a content clip (its x0 prediction against the
  frozen prior's, from the same noisy input) must shift the per-channel time means (and log standard
  deviations) of the body's features as the example differs from its neutral pair (after the AdaIN line of
  work and Holden et al. 2016's Gram matching, taken as a *difference*, so the content's own pose stays).
- :func:`directional_loss`: in the motion encoder's space, the change ``E(styled) - E(prior's)`` must point
  the way ``E(example) - E(pair)`` does (as directional CLIP losses do for image domain adaptation).
"""
from __future__ import annotations

import torch
from torch.nn import functional as F

from motioncore.representation import FEATURES

# The body's channels: root height, joint positions and rotations. The root's path is inpainted (never
# changed by a style) and the contact flags follow from the positions.
STAT_CHANNELS = torch.cat([torch.arange(FEATURES.root_height.start, FEATURES.root_height.stop),
                           torch.arange(FEATURES.positions.start, FEATURES.positions.stop),
                           torch.arange(FEATURES.rotations.start, FEATURES.rotations.stop)])
STD_FLOOR = 1e-2  # in normalised units: a channel that does not move has no scale to change


def time_stats(x: torch.Tensor, valid: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-channel mean and log standard deviation over time of the body channels of normalised features
    ``x (B, T, D)`` over the ``valid (B, T)`` frames -> two ``(B, C)``, C = ``len(STAT_CHANNELS)``."""
    if x.ndim != 3 or x.shape[-1] != FEATURES.dim:
        raise ValueError(f"time_stats: expected features (B, T, {FEATURES.dim}), got {tuple(x.shape)}")
    x = x[..., STAT_CHANNELS.to(x.device)]
    w = torch.ones(x.shape[:2], dtype=x.dtype, device=x.device) if valid is None else valid.to(x.dtype)
    n = w.sum(1, keepdim=True).clamp_min(1)
    mean = (x * w[..., None]).sum(1) / n
    var = (((x - mean[:, None]) ** 2) * w[..., None]).sum(1) / n
    return mean, 0.5 * torch.log(var.clamp_min(STD_FLOOR ** 2))


def style_shift(example: torch.Tensor, pair: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """What the example changes against its neutral pair, both normalised ``(T, D)`` on one path:
    ``(mean shift (C,), log-std shift (C,))``."""
    (m_e, s_e), (m_p, s_p) = time_stats(example[None]), time_stats(pair[None])
    return (m_e - m_p)[0], (s_e - s_p)[0]


POSTURE_FRAMES = 20  # frames over which a motion's channels are taken to be correlated (a second: about one step)


def posture_shift(example: torch.Tensor, pair: torch.Tensor) -> torch.Tensor:
    """Where the example holds its body against its neutral pair, both normalised ``(T, D)`` on one path: the
    time-mean of ``example - pair`` over the body channels ``(C,)``, each shrunk by how sure it is,
    ``m^2 / (m^2 + se^2)`` with ``se`` the mean's standard error (the difference's spread over time, about one
    independent sample per :data:`POSTURE_FRAMES`). An offset held all along is kept; one that a few steps out
    of phase with the pair make up (the feet's forward places in a short walk) is dropped."""
    if example.ndim != 2 or example.shape != pair.shape or example.shape[-1] != FEATURES.dim:
        raise ValueError(f"posture_shift: expected example and pair (T, {FEATURES.dim}) alike, got "
                         f"{tuple(example.shape)} and {tuple(pair.shape)}")
    d = (example - pair)[:, STAT_CHANNELS.to(example.device)]
    mean = d.mean(0)
    se2 = d.var(0, unbiased=False) / max(1.0, d.shape[0] / POSTURE_FRAMES)
    return mean * mean ** 2 / (mean ** 2 + se2).clamp_min(1e-12)


def neutral_shift(example: torch.Tensor, neutral: list[torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
    """What the example ``(T, D)`` changes against neutral clips of its action (normalised ``(T_i, D)``, their
    statistics averaged): ``(mean shift (C,), log-std shift (C,))``."""
    if not neutral:
        raise ValueError("neutral_shift: expected at least one neutral clip")
    m_e, s_e = time_stats(example[None])
    stats = [time_stats(x[None].to(example.device)) for x in neutral]
    m_n = torch.stack([m for m, _ in stats]).mean(0)
    s_n = torch.stack([s for _, s in stats]).mean(0)
    return (m_e - m_n)[0], (s_e - s_n)[0]


def statistics_loss(x0_style: torch.Tensor, x0_prior: torch.Tensor, valid: torch.Tensor,
                    shift: tuple[torch.Tensor, torch.Tensor], use_std: bool = True) -> torch.Tensor:
    """Mean squared error between the statistics change the style model makes on the content batch
    (``x0_style`` against ``x0_prior``, both ``(B, T, D)`` over ``valid (B, T)``) and ``shift``
    (:func:`style_shift`), over the body channels; ``use_std`` False: the means only."""
    m_s, s_s = time_stats(x0_style, valid)
    m_p, s_p = time_stats(x0_prior, valid)
    loss = ((m_s - m_p - shift[0]) ** 2).mean()
    if use_std:
        loss = loss + ((s_s - s_p - shift[1]) ** 2).mean()
    return loss


def directional_loss(z_style: torch.Tensor, z_prior: torch.Tensor, direction: torch.Tensor) -> torch.Tensor:
    """``1 - cos(z_style - z_prior, direction)`` averaged over the batch: embeddings ``(B, E)``, ``direction (E,)``."""
    return (1 - F.cosine_similarity(z_style - z_prior, direction[None].expand_as(z_style), dim=-1, eps=1e-8)).mean()


def statistics_direction_loss(x0_style: torch.Tensor, x0_prior: torch.Tensor, valid: torch.Tensor,
                              shift: tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
    """``1 - cos`` between the statistics change the style model makes on each content clip (``x0_style`` against
    ``x0_prior``, both ``(B, T, D)`` over ``valid (B, T)``: means and log standard deviations of the body channels,
    :func:`time_stats`) and the example's change against its pair, ``shift`` (:func:`style_shift`), averaged over
    the batch: the direction of the change is asked for, its size is left to the reconstruction."""
    m_s, s_s = time_stats(x0_style, valid)
    m_p, s_p = time_stats(x0_prior, valid)
    change = torch.cat([m_s - m_p, s_s - s_p], -1)
    target = torch.cat(shift)[None].expand_as(change)
    return (1 - F.cosine_similarity(change, target, dim=-1, eps=1e-8)).mean()
