"""What an animator sees change in a walk (evaluation.metrics.gait_measures), on the project's own sample clips."""
import math
from pathlib import Path

import pytest
import torch

from evaluation.metrics import gait_measures
from motioncore import quat
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL
from video2style.pipeline import read_clip

SAMPLES = Path(__file__).resolve().parent.parent / "samples"


def test_a_walk_steps_and_swings_as_walks_do():
    g = gait_measures(read_clip(SAMPLES / "walk_prior.bvh").canonical)
    assert 80 <= g["cadence_spm"] <= 140  # people walk at 100-120 steps a minute
    assert 40 <= g["step_cm"] <= 90
    assert 20 <= g["arm_swing_cm"] <= 60
    assert abs(g["lean_deg"]) < 5


def test_a_wave_done_in_place_has_no_steps():
    g = gait_measures(read_clip(SAMPLES / "wave_right_hand_prior.bvh").canonical)
    assert math.isnan(g["step_cm"]) and math.isnan(g["cadence_spm"])
    assert g["arm_swing_cm"] < 10


def test_bending_the_spine_forward_adds_its_angle_to_the_lean():
    walk = read_clip(SAMPLES / "walk_prior.bvh").canonical
    spine = CANONICAL.skeleton.names.index("Spine")
    lrot = walk.lrot.clone()
    bend = quat.from_axis_angle(torch.tensor([1.0, 0.0, 0.0]), torch.tensor(math.radians(15.0)))
    lrot[:, spine] = quat.mul(bend.expand_as(lrot[:, spine]), lrot[:, spine])
    bent = Motion(walk.skeleton, lrot, walk.lpos, walk.fps)
    change = gait_measures(bent)["lean_deg"] - gait_measures(walk)["lean_deg"]
    assert 8 < abs(change) < 16  # the spine's bend, less the part below it (Hips -> Neck)


def test_gait_refuses_a_clip_under_a_second():
    walk = read_clip(SAMPLES / "walk_prior.bvh").canonical
    with pytest.raises(ValueError, match="at least a second"):
        gait_measures(walk.slice(0, 5))


def test_a_foot_set_down_twice_in_one_stance_is_one_step():
    from evaluation.metrics import _steps

    assert _steps([True, True, False, False, False, False, True, True], gap=4) == 1  # standing at the start: no step
    assert _steps([False, True, True, False, True, True, False, False, False, False, False, True], gap=4) == 2
    assert _steps([False, True, False, True], gap=1) == 2
    assert _steps([True] * 8, gap=4) == 0
