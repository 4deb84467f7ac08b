"""The measure of a stoop benchmarks/demo_still.py reports (evaluation.metrics.trunk_lean): known values on a tilted rest pose."""
import math

import pytest
import torch

from evaluation.metrics import trunk_lean
from motioncore import quat
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion

SK = CANONICAL.skeleton


def _tilted(degrees: float, yaw: float = 0.0, frames: int = 5) -> Motion:
    """The rest pose, the whole body turned by ``degrees`` about the lateral axis (+X), then by ``yaw``."""
    j = len(SK.names)
    lrot = quat.identity(frames, j)
    tilt = quat.from_axis_angle(torch.tensor([1.0, 0.0, 0.0]), torch.tensor(math.radians(degrees)))
    lrot[:, 0] = quat.mul(quat.from_yaw(torch.tensor(yaw)), tilt)
    lpos = SK.offsets.expand(frames, j, 3).clone()
    lpos[:, 0] = torch.tensor([0.3, 0.95, -1.0])
    return Motion(SK, lrot, lpos, 30.0)


@pytest.mark.parametrize("yaw", [0.0, 1.2, -2.5])
def test_trunk_lean_reads_a_forward_tilt_whatever_the_facing(yaw):
    assert trunk_lean(_tilted(0.0, yaw)) == pytest.approx(0.0, abs=0.5)
    assert trunk_lean(_tilted(30.0, yaw)) == pytest.approx(30.0, abs=0.5)  # +X turns up towards forward (+Z)
    assert trunk_lean(_tilted(-15.0, yaw)) == pytest.approx(-15.0, abs=0.5)


def test_trunk_lean_refuses_a_foreign_skeleton():
    m = random_motion(seconds=0.2)
    foreign = Motion(type(SK)(tuple(f"j{k}" for k in range(len(SK.names))), SK.parents, SK.offsets), m.lrot, m.lpos, m.fps)
    with pytest.raises(ValueError, match="canonical skeleton"):
        trunk_lean(foreign)
