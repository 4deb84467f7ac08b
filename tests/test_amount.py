"""The calibrated amount of a style (transfer.amount): known distances, the gain's arithmetic and bounds, how
--strength and the gain combine, the style file's field, and learning recording it (toy models)."""
from __future__ import annotations

import math

import pytest
import torch

from mlcore.dataset import MotionDataset
from motioncore.representation import FEATURES
from tests.helpers import toy_learn_config
from transfer.amount import (
    GAIN_RANGE,
    calibrate_gain,
    calibration_clips,
    describe_amount,
    style_distance,
)
from transfer.learn import learn_style
from transfer.style_config import STRENGTH_AMOUNT, ApplyConfig, LearnConfig, strength_settings, style_amount
from transfer.style_file import Style, validate_meta
from transfer.style_losses import STAT_CHANNELS


def _motion(seed=0, frames=40):
    return torch.randn(frames, FEATURES.dim, generator=torch.Generator().manual_seed(seed))


def test_style_distance_known_values():
    x = _motion()
    assert style_distance(x, x) == 0.0
    shifted = x.clone()
    shifted[:, STAT_CHANNELS] += 0.3  # every body channel held 0.3 further: means move, spreads do not
    assert style_distance(shifted, x) == pytest.approx(0.3 / math.sqrt(2), rel=1e-5)
    wider = x.clone()
    mean = x[:, STAT_CHANNELS].mean(0)
    wider[:, STAT_CHANNELS] = mean + 2 * (x[:, STAT_CHANNELS] - mean)  # every swing doubled
    assert style_distance(wider, x) == pytest.approx(math.log(2) / math.sqrt(2), rel=1e-4)
    other = x.clone()
    other[:, FEATURES.root_lvel] += 5.0  # the path is not style
    assert style_distance(other, x) == 0.0
    with pytest.raises(ValueError, match="expected two motions"):
        style_distance(x[0], x)


def test_calibrate_gain_scales_to_the_target_within_its_range():
    clips = [_motion(s) for s in range(3)]

    def nudge(c):  # a style that holds every body channel 0.1 further
        out = c.clone()
        out[:, STAT_CHANNELS] += 0.1
        return out

    reached = 0.1 / math.sqrt(2)
    gain, got = calibrate_gain(nudge, 2 * reached, clips)
    assert got == pytest.approx(reached, rel=1e-5) and gain == pytest.approx(2.0, rel=1e-4)
    assert calibrate_gain(nudge, 100.0, clips)[0] == GAIN_RANGE[1]
    assert calibrate_gain(nudge, 1e-4, clips)[0] == GAIN_RANGE[0]
    assert calibrate_gain(lambda c: c, 0.5, clips) == (1.0, 0.0)  # a style that does not move them
    assert calibrate_gain(nudge, 0.5, []) == (1.0, 0.0)
    assert "4.0x" in describe_amount(2.0, 0.14, 0.07) and "as much as the example shows" in describe_amount(2.0, 0.14, 0.07)
    plain = describe_amount(1.0, 0.85, None)  # not calibrated: the example's distance and the default amount
    assert "by 0.85" in plain and "0.5 applies the learned change 2.0x, 1 applies it 4.0x" in plain
    assert "most the tool applies" in describe_amount(GAIN_RANGE[1], 9.0, 0.07)


def test_strength_and_gain_multiply_the_difference():
    learn, apply = LearnConfig(), ApplyConfig()
    _, cfg = strength_settings(0.5, learn, apply, gain=1.6)
    assert cfg.style_scale == pytest.approx(STRENGTH_AMOUNT * 1.6 * apply.style_scale)
    _, cfg0 = strength_settings(0.0, learn, apply, gain=1.6)
    assert cfg0.style_scale == 0.0  # --strength 0: the content, whatever the gain
    _, cfg1 = strength_settings(None, learn, apply, gain=1.6)
    assert cfg1.style_scale == pytest.approx(STRENGTH_AMOUNT * 1.6 * apply.style_scale)
    assert strength_settings(0.5, learn, apply)[1].style_scale == pytest.approx(STRENGTH_AMOUNT * apply.style_scale)
    assert style_amount(0.5, 1.6) == pytest.approx(STRENGTH_AMOUNT * 1.6) and style_amount(1.0) == 2 * STRENGTH_AMOUNT
    assert style_amount(None) == style_amount(0.5) and style_amount(0.0, 3.0) == 0.0
    with pytest.raises(ValueError, match="strength: expected a number from 0 to 1"):
        style_amount(1.2)


def test_a_style_files_amount_is_read_and_checked():
    assert Style({}, {}).gain == 1.0  # files from before: as learned
    assert Style({}, {"amount": {"gain": 1.7, "target": 0.9, "reached": 0.5}}).gain == 1.7
    validate_meta({"amount": {"gain": 1.7, "target": 0.9, "reached": 0.5}})
    for bad in ({"gain": 50.0}, {"gain": "2"}, {"gain": float("nan")}, {"gain": 1.0, "evil": 1}, [1.0]):
        with pytest.raises(ValueError, match="amount"):
            validate_meta({"amount": bad})


@pytest.mark.slow
def test_learning_records_the_calibrated_amount(toys):
    bundle, cache = toys
    data = MotionDataset(cache, "train")
    assert calibration_clips(data)  # the synthetic cache has a neutral walk
    style, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config(calibrate=True))
    amount = style.meta["amount"]
    assert set(amount) == {"gain", "target", "reached"} and GAIN_RANGE[0] <= amount["gain"] <= GAIN_RANGE[1]
    assert amount["target"] > 0 and style.gain == amount["gain"]
    again, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config(calibrate=True))
    assert again.meta["amount"] == amount  # seeded: the same amount
    plain, _ = learn_style(bundle, data, data.clip(1), "old", "walk", toy_learn_config())  # the default: gain 1
    assert "amount" not in plain.meta and plain.gain == 1.0
