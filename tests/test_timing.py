"""Spans (--start/--end), time warps (--tempo) and root speed: known values."""
from __future__ import annotations

import math

import pytest
import torch

from motioncore.motion import root_speed, time_warp, trim
from motioncore.span import check_span
from testkit.motions import random_motion


def test_trim_keeps_the_frames_inside_the_span():
    m = random_motion(seconds=5.0, fps=20.0)
    cut = trim(m, (1.0, 2.5), "clip.bvh")
    assert cut.num_frames == 30 and torch.equal(cut.lrot, m.lrot[20:50])
    assert trim(m, (None, 1.0), "x").num_frames == 20 and trim(m, (4.0, None), "x").num_frames == 20
    with pytest.raises(ValueError, match=r"clip.bvh: --start/--end select no frames \(the clip is 5.00 s long\)"):
        trim(m, (6.0, None), "clip.bvh")
    for bad, msg in [((2.0, 1.0), "must be after"), ((-1.0, None), "--start expected"), ((None, math.inf), "--end expected")]:
        with pytest.raises(ValueError, match=msg):
            check_span(bad, "clip.bvh")


def test_time_warp_slows_the_same_path():
    m = random_motion(seconds=4.0, fps=20.0)
    slow = time_warp(m, 0.8)
    assert slow.fps == m.fps and abs(slow.num_frames - 100) <= 1
    assert torch.allclose(slow.lpos[0, 0], m.lpos[0, 0]) and torch.allclose(slow.lpos[-1, 0], m.lpos[-1, 0], atol=1e-5)
    assert root_speed(slow) == pytest.approx(0.8 * root_speed(m), rel=0.02)
    with pytest.raises(ValueError, match="tempo"):
        time_warp(m, 0.0)


def test_root_speed_known_value():
    m = random_motion(seconds=3.0)
    m.lpos[:, 0, 0], m.lpos[:, 0, 2] = 0.0, 1.1 * torch.arange(m.num_frames) / m.fps
    assert root_speed(m) == pytest.approx(1.1, rel=1e-4)
