"""Word-free style signals (transfer.style_losses): statistics over time and directions, with known values."""
from __future__ import annotations

import pytest
import torch

from motioncore.representation import FEATURES
from transfer.style_losses import (
    STAT_CHANNELS,
    STD_FLOOR,
    directional_loss,
    neutral_shift,
    statistics_loss,
    style_shift,
    time_stats,
)


def test_body_channels_leave_out_the_root_path_and_contacts():
    chans = set(STAT_CHANNELS.tolist())
    for sl in (FEATURES.root_rvel, FEATURES.root_lvel, FEATURES.contacts):
        assert not chans & set(range(sl.start, sl.stop))
    assert set(range(FEATURES.rotations.start, FEATURES.rotations.stop)) <= chans


def test_time_stats_known_values_and_mask():
    x = torch.zeros(1, 4, FEATURES.dim)
    x[0, :, STAT_CHANNELS[0]] = torch.tensor([1.0, 3.0, 100.0, -50.0])
    valid = torch.tensor([[True, True, False, False]])
    mean, log_std = time_stats(x, valid)
    assert mean.shape == (1, len(STAT_CHANNELS))
    assert mean[0, 0] == pytest.approx(2.0) and log_std[0, 0] == pytest.approx(0.0, abs=1e-6)  # std of (1, 3) is 1
    assert log_std[0, 1] == pytest.approx(torch.log(torch.tensor(STD_FLOOR)).item())  # a still channel: the floor
    with pytest.raises(ValueError, match="expected features"):
        time_stats(torch.zeros(4, FEATURES.dim))


def test_statistics_loss_is_zero_for_the_asked_shift_and_not_otherwise():
    g = torch.Generator().manual_seed(0)
    example, pair = torch.randn(30, FEATURES.dim, generator=g), torch.randn(30, FEATURES.dim, generator=g)
    assert all(torch.allclose(s, torch.zeros_like(s)) for s in style_shift(example, example))
    shift = style_shift(example, pair)
    x0_prior = torch.randn(2, 20, FEATURES.dim, generator=g)
    valid = torch.ones(2, 20, dtype=torch.bool)
    m, _ = time_stats(x0_prior, valid)
    # the prior's output rescaled about its mean and moved, channel by channel, as the shift asks
    styled = x0_prior.clone()
    c = STAT_CHANNELS
    styled[..., c] = (x0_prior[..., c] - m[:, None]) * torch.exp(shift[1]) + m[:, None] + shift[0]
    assert statistics_loss(styled, x0_prior, valid, shift) == pytest.approx(0.0, abs=1e-8)
    assert statistics_loss(x0_prior, x0_prior, valid, shift) > 0.1
    means_only = x0_prior.clone()
    means_only[..., c] += shift[0]
    assert statistics_loss(means_only, x0_prior, valid, shift, use_std=False) == pytest.approx(0.0, abs=1e-8)
    # against neutral clips: the same as against a pair when the one neutral clip is that pair
    assert all(torch.allclose(a, b) for a, b in zip(neutral_shift(example, [pair]), shift))
    with pytest.raises(ValueError, match="at least one neutral clip"):
        neutral_shift(example, [])


def test_directional_loss_known_values():
    d = torch.tensor([1.0, 0.0, 0.0])
    z_prior = torch.zeros(2, 3)
    assert directional_loss(torch.tensor([[2.0, 0, 0], [0.5, 0, 0]]), z_prior, d) == pytest.approx(0.0)
    assert directional_loss(torch.tensor([[-1.0, 0, 0], [-3.0, 0, 0]]), z_prior, d) == pytest.approx(2.0)
    assert directional_loss(torch.tensor([[0.0, 1.0, 0]]), z_prior[:1], d) == pytest.approx(1.0)


def test_statistics_direction_loss_asks_for_the_direction_only():
    from transfer.style_losses import STAT_CHANNELS, statistics_direction_loss

    torch.manual_seed(0)
    prior = torch.randn(3, 30, FEATURES.dim)
    valid = torch.ones(3, 30, dtype=torch.bool)
    offset = torch.zeros(FEATURES.dim)
    offset[STAT_CHANNELS[:5]] = torch.tensor([0.5, -0.2, 0.1, 0.3, -0.4])
    shift = (offset[STAT_CHANNELS], torch.zeros(len(STAT_CHANNELS)))
    for size in (0.1, 2.0):  # any size of the same change: no loss
        assert statistics_direction_loss(prior + size * offset, prior, valid, shift) < 1e-5
    assert abs(float(statistics_direction_loss(prior - offset, prior, valid, shift)) - 2.0) < 1e-5  # the opposite way


def test_posture_shift_keeps_a_held_offset_and_drops_one_made_up_by_phase():
    from transfer.style_losses import STAT_CHANNELS, posture_shift

    t = torch.arange(80, dtype=torch.float32)
    pair = torch.zeros(80, FEATURES.dim)
    pair[:, STAT_CHANNELS[0]] = torch.sin(2 * torch.pi * t / 20)
    example = pair.clone()
    example[:, STAT_CHANNELS[1]] += 0.3  # held all along
    example[:, STAT_CHANNELS[0]] = torch.sin(2 * torch.pi * (t + 3) / 20 + 0.4) + 0.05  # out of phase, a small mean
    shift = posture_shift(example, pair)
    assert shift.shape == (len(STAT_CHANNELS),)
    assert abs(float(shift[1]) - 0.3) < 1e-4
    assert abs(float(shift[0])) < 0.01  # 0.05 of mean under a spread of ~0.9: dropped
    assert torch.count_nonzero(shift[2:]) == 0
    with pytest.raises(ValueError, match="expected example and pair"):
        posture_shift(example, pair[:10])
