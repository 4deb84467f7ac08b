"""Bone rolls of foreign rigs brought into the training data's convention (motioncore.ik_fit.conform_rolls)."""
from __future__ import annotations

import math

import pytest
import torch

from motioncore import quat
from motioncore.ik_fit import (
    ROLL_CONVENTION_DEG,
    conform_rolls,
    default_reference,
    roll_deviation,
)
from motioncore.kinematics import fk, to_local
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL

SK = CANONICAL.skeleton
# what a shortest-arc retarget of a foreign rig does to the data's convention (measured on Xia and fair1)
FOREIGN_ROLLS_DEG = {"Spine": -90.0, "Shoulder_L": 90.0, "Shoulder_R": 90.0, "UpperLeg_R": 166.0, "LowerArm_L": 70.0}


def convention_motion(n: int = 60, seed: int = 0, spread: float = 0.2) -> Motion:
    """Smooth random local rotations around the data's reference pose, a walking root."""
    g = torch.Generator().manual_seed(seed)
    t = torch.linspace(0, 1, n)[:, None, None]
    a, b = torch.randn(2, 1, SK.num_joints, 3, generator=g) * spread
    axis_angle = a * torch.sin(3 * t) + b * torch.cos(2 * t)
    delta = quat.from_axis_angle(torch.nn.functional.normalize(axis_angle, dim=-1), axis_angle.norm(dim=-1))
    lrot = quat.mul(default_reference().expand(n, -1, -1), delta)
    lpos = SK.offsets.expand(n, -1, -1).clone()
    lpos[:, 0] = torch.cat([0.1 * torch.sin(4 * t[:, 0]), 0.9 + 0.02 * t[:, 0], 1.5 * t[:, 0]], -1)
    return Motion(SK, lrot, lpos, 20.0)


def rolled(motion: Motion, rolls_deg: dict[str, float]) -> Motion:
    """``motion`` with the named single-child bones turned about themselves, a leaf below one turned with it (as
    a retargeted rig's hand takes its forearm's frame): the same joint positions."""
    grot, _ = fk(motion.lrot, motion.lpos, SK.parents)
    grot = grot.clone()
    for name, deg in rolls_deg.items():
        j = SK.index(name)
        (child,) = SK.children(j)
        axis = torch.nn.functional.normalize(SK.offsets[child], dim=0)
        turn = quat.from_axis_angle(axis, torch.tensor(math.radians(deg)))
        for k in (j, child) if not SK.children(child) else (j,):
            grot[:, k] = quat.mul(grot[:, k], turn)
    return Motion(SK, to_local(grot, SK.parents), motion.lpos, motion.fps)


def test_a_motion_in_the_convention_is_returned_as_it_is():
    m = convention_motion()
    assert roll_deviation(m) < 30
    assert conform_rolls(m) is m
    assert conform_rolls(rolled(m, FOREIGN_ROLLS_DEG), force=False).lrot.equal(rolled(m, FOREIGN_ROLLS_DEG).lrot)


@pytest.mark.parametrize("seed", [0, 1])
def test_foreign_rolls_are_solved_back_into_the_convention(seed):
    m = convention_motion(seed=seed)
    foreign = rolled(m, FOREIGN_ROLLS_DEG)
    torch.testing.assert_close(foreign.global_positions(), m.global_positions(), atol=1e-5, rtol=0)
    assert roll_deviation(foreign) > ROLL_CONVENTION_DEG
    fixed = conform_rolls(foreign)
    assert roll_deviation(fixed) < 30
    err = (fixed.global_positions() - m.global_positions()).norm(dim=-1)
    assert float(err.max()) < 1e-4  # metres: only the rolls change
    for name in FOREIGN_ROLLS_DEG:  # each rolled bone's frame is back near the original's
        j = SK.index(name)
        gap = torch.rad2deg(quat.angle(quat.mul(quat.inv(m.lrot[:, j]), fixed.lrot[:, j])))
        assert float(gap.median()) < 40, name


def test_kept_leaves_turn_with_their_parent():
    """A hand that does not move against its forearm keeps not moving against it after the solve."""
    m = convention_motion()
    hand, wrist_turn = SK.index("Hand_L"), quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]), torch.tensor(0.3))
    lrot = m.lrot.clone()
    lrot[:, hand] = wrist_turn
    foreign = rolled(Motion(SK, lrot, m.lpos, m.fps), FOREIGN_ROLLS_DEG)
    fixed = conform_rolls(foreign)
    angle = quat.angle(fixed.lrot[:, hand])
    torch.testing.assert_close(angle, torch.full_like(angle, 0.3), atol=1e-4, rtol=0)


def test_force_solves_a_motion_in_the_convention_too():
    m = convention_motion()
    fixed = conform_rolls(m, force=True)
    assert fixed is not m
    err = (fixed.global_positions() - m.global_positions()).norm(dim=-1)
    assert float(err.max()) < 1e-4


def test_roll_deviation_wants_the_canonical_skeleton():
    from testkit.motions import bandai_like_skeleton

    sk = bandai_like_skeleton()
    m = Motion(sk, quat.identity(3, sk.num_joints), sk.offsets.expand(3, -1, -1).clone(), 20.0)
    with pytest.raises(ValueError, match="canonical skeleton"):
        roll_deviation(m)
