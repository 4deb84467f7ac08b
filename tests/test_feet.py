"""Clean feet and smooth limbs (issue 50): contacts with hysteresis, contacts held on the content's floor, spikes
drawn out, --feet, --strength 0 giving the content back, the line telling low steps from slides. Motions made here."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import pytest
import torch

from motioncore import quat
from motioncore.cleanup import FeetConfig, _swing_lift, cleanup_feet, eased_targets, relock_legs
from motioncore.feet import (
    ContactConfig,
    contact_flags,
    contact_runs,
    feet_measures,
    low_steps,
    peak_acceleration,
    swing_clearance,
)
from motioncore.kinematics import rest_positions
from motioncore.motion import Motion
from motioncore.representation import foot_contacts
from motioncore.skeleton import CANONICAL
from motioncore.smooth import limit_acceleration
from testkit.motions import random_motion

SAMPLES = Path(__file__).resolve().parents[1] / "samples"

SK = CANONICAL.skeleton


def _standing(frames: int = 40, lift: float = 0.0) -> Motion:
    """The canonical rest pose standing on y = 0 (toes at 0), the hips raised by ``lift`` metres."""
    rest = rest_positions(SK.offsets, SK.parents)
    lrot = quat.identity(frames, SK.num_joints)
    lpos = SK.offsets.expand(frames, -1, -1).clone()
    lpos[:, 0, 1] = -rest[:, 1].min() + lift
    return Motion(SK, lrot, lpos, CANONICAL.fps)


def _feet_at(heights: torch.Tensor) -> torch.Tensor:
    """Positions ``(T, J, 3)``: every joint at the origin but the four foot joints, at ``heights (T,)`` above their
    rest heights (the ankle 5 cm above the toes), still."""
    rest = rest_positions(SK.offsets, SK.parents)
    off = rest[list(CANONICAL.feet), 1] - rest[list(CANONICAL.feet), 1].min()
    gpos = torch.zeros(heights.shape[0], SK.num_joints, 3)
    gpos[:, list(CANONICAL.feet), 1] = heights[:, None] + off
    return gpos


def test_contacts_hold_through_a_noisy_frame_with_hysteresis():
    h = torch.full((20,), 0.02)
    h[8] = 0.065  # one frame just over the contact height: the old flags break the contact there
    h[14:] = 0.2  # the foot lifts clearly
    gpos = _feet_at(h)
    flags = contact_flags(gpos, CANONICAL.fps)
    old = foot_contacts(gpos, CANONICAL.fps) > 0.5
    assert not bool(old[8, 0])  # before: the contact broke
    assert contact_runs(flags[:, 0]) == [(0, 13)]  # one contact, till the lift
    assert contact_runs(flags[:, 1]) == [(0, 13)]
    with pytest.raises(ValueError, match="expected positions"):
        contact_flags(torch.zeros(5, 3), 20.0)


def test_a_floating_standing_result_is_put_on_the_content_s_floor():
    content = _standing()
    result = _standing(lift=0.02)  # the style lifted the whole body 2 cm: the feet float where the content stands
    out = cleanup_feet(result, reference=content, config=FeetConfig(lower_hips=True))
    feet = list(CANONICAL.feet)
    got, want = out.global_positions()[:, feet], content.global_positions()[:, feet]
    assert (got - want).norm(dim=-1).max() < 1e-3  # within 1 mm of the content's floor (before: 2 cm above it)
    m = feet_measures(out.global_positions(), content.global_positions(), CANONICAL.fps)
    assert m.floor_worst < 1e-3 and m.drift_worst < 1e-3 and m.contacts == 4
    kept = cleanup_feet(result, reference=content)  # by default the hips stay: the straight legs cannot reach down
    assert torch.allclose(kept.lpos, result.lpos)


def test_cleanup_holds_a_sliding_planted_foot_without_a_jump():
    content = _standing(frames=60)
    lpos = content.lpos.clone()
    lpos[:, 0, 0] += 0.04 * torch.sin(torch.arange(60) * 0.3)  # the hips sway: the feet slide 4 cm with them
    result = Motion(SK, content.lrot, lpos, content.fps)
    before = feet_measures(result.global_positions(), content.global_positions(), content.fps)
    out = cleanup_feet(result, reference=content)
    after = feet_measures(out.global_positions(), content.global_positions(), content.fps)
    assert before.drift_worst > 0.03 and after.drift_worst < 0.003 and after.jump_worst < 0.002


def test_eased_targets_slow_a_foot_into_its_contact():
    t = torch.arange(30.0)
    free = torch.stack([0.05 * t, torch.zeros(30), torch.zeros(30)], -1)  # 1 m/s straight through
    locked = torch.zeros(30, dtype=torch.bool)
    locked[15:22] = True
    held = free.clone()
    held[15:22] = free[18]
    out = eased_targets(free, held, locked, bridge=6)
    assert torch.allclose(out[15:22], held[15:22])
    step = (out[1:] - out[:-1]).norm(dim=-1)
    assert step[14] < 0.03 and step[22] < 0.03  # slowed coming in and going out (the motion's: 5 cm a frame)
    assert peak_acceleration(out[:, None], 20.0) < 25.0  # a stop from 1 m/s at once would be 20 m/s^2 in one frame


def test_a_single_frame_spike_is_drawn_out_and_a_smooth_motion_left_alone():
    m = random_motion(seconds=3.0, seed=3, amplitude=0.2)
    lrot = m.lrot.clone()
    arm = SK.index("LowerArm_L")
    lrot[30, arm] = quat.mul(quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]), torch.tensor(1.0)), lrot[30, arm])
    spiky = Motion(SK, lrot, m.lpos, m.fps)
    base = peak_acceleration(m.global_positions(), m.fps)
    assert peak_acceleration(spiky.global_positions(), m.fps) > 3 * base
    out = limit_acceleration(spiky, 1.4 * base)
    assert peak_acceleration(out.global_positions(), m.fps) <= 1.4 * base + 1e-3
    assert limit_acceleration(m, 1.5 * base) is m  # nothing over the limit: the motion itself
    frozen = torch.zeros(m.num_frames, SK.num_joints, dtype=torch.bool)
    frozen[:, arm] = True
    kept = limit_acceleration(spiky, 1.4 * base, frozen=frozen)
    assert torch.equal(kept.lrot[:, arm], spiky.lrot[:, arm])  # frozen joints untouched


def test_a_swing_is_raised_to_the_example_s_clearance_and_never_lowered():
    planted = torch.zeros(30, dtype=torch.bool)
    planted[:8] = planted[20:] = True
    toe_h = torch.zeros(30)
    toe_h[8:20] = 0.01 * torch.sin(math.pi * torch.arange(1, 13) / 13)  # a 1 cm shuffle
    ref_toe = torch.zeros(30, 3)
    ref_toe[20:, 2] = 0.6  # the content steps 60 cm
    lift = _swing_lift(toe_h, ref_toe, planted, 0.05, 0.10, 0.04)
    assert lift[:8].abs().max() == 0 and lift[20:].abs().max() == 0
    assert abs(float((toe_h + lift).max()) - 0.05) < 0.002  # raised to the example's 5 cm
    assert _swing_lift(toe_h, ref_toe, planted, 0.005, 0.10, 0.04).abs().max() == 0  # already clears: kept
    assert float(_swing_lift(toe_h, ref_toe, planted, 0.5, 0.10, 0.04).max()) <= 0.04 + 1e-6  # at most max_lift
    still = torch.zeros(30, 3)  # a foot that does not travel: no step to raise
    assert _swing_lift(toe_h, still, planted, 0.05, 0.10, 0.04).abs().max() == 0


def test_swing_clearance_and_low_steps_read_a_walk():
    t = torch.arange(60)
    h = torch.zeros(60)
    for s in (10, 30, 50):  # three swings 8 cm high, each foot planted between them
        h[s:s + 6] = 0.08 * torch.sin(math.pi * torch.arange(1, 7) / 7)
    gpos = _feet_at(h)
    gpos[:, list(CANONICAL.feet), 2] = (t.float() * 0.0)[:, None]
    assert swing_clearance(gpos, 20.0) == pytest.approx(0.08 * math.sin(math.pi * 3 / 7), abs=1e-3)
    assert swing_clearance(_feet_at(torch.zeros(60)), 20.0) is None  # in place: no swing
    skim = gpos.clone()
    skim[:, list(CANONICAL.feet), 1] = _feet_at(torch.zeros(60))[:, list(CANONICAL.feet), 1]
    skim[:, list(CANONICAL.feet), 0] = (t.float() * 0.05)[:, None]  # a foot dragged along the floor, 1 m/s
    assert low_steps(skim, gpos, 20.0) > 0.2  # read where the content swings


def test_feet_option_once_for_apply_and_batch():
    from video2style.options import ApplyOptions, add_apply_options, apply_options

    parser = argparse.ArgumentParser()
    add_apply_options(parser)
    assert apply_options(parser.parse_args([])).feet == "auto"
    assert apply_options(parser.parse_args(["--feet", "lock"])).feet == "lock"
    with pytest.raises(SystemExit):
        parser.parse_args(["--feet", "sometimes"])
    with pytest.raises(ValueError, match="--feet: expected"):
        ApplyOptions(feet="sometimes").check()


class _FakeStyle:
    """Enough of a style for --strength 0, which reads none of it but its configs and example."""

    example = None

    def configs(self):
        from transfer.style_config import ApplyConfig, LearnConfig

        return LearnConfig(), ApplyConfig()


def test_strength_zero_returns_the_content_itself_and_writes_it_back_within_a_tenth_of_a_mm(tmp_path):
    from motioncore.bvh import read_bvh
    from transfer.spans import stylize_motion
    from video2style.pipeline import read_clip, write_result

    clip = read_clip(SAMPLES / "walk_prior.bvh")
    result, info = stylize_motion(None, _FakeStyle(), None, clip.canonical, 0.0)
    assert torch.equal(result.lrot, clip.canonical.lrot) and torch.equal(result.lpos, clip.canonical.lpos)
    assert info["skating_after"] == info["skating_content"] and not info["neutralized"]
    write_result(clip, result, tmp_path / "out.bvh")
    written, _ = read_bvh(tmp_path / "out.bvh")
    err = (written.global_positions() - clip.source.global_positions()).norm(dim=-1).max() * clip.rig.scale
    assert float(err) < 1e-4  # metres: the content on its own skeleton within 0.1 mm


def test_auto_leaves_the_feet_when_locking_them_slides_more_where_planted(monkeypatch):
    import transfer.spans as spans
    from transfer.spans import ExampleFeet, clean_feet

    content = _standing(frames=40)
    lpos = content.lpos.clone()
    lpos[:, 0, 0] += torch.arange(40) * 0.05  # dragged along the floor at 1 m/s: it slides
    sliding = Motion(SK, content.lrot, lpos, content.fps)
    monkeypatch.setattr(spans, "cleanup_feet", lambda raw, **kw: sliding)  # a cleanup that made it worse
    raw = content
    out, info = clean_feet(raw, content, "auto", None, ExampleFeet(), slice(0, 40))
    assert out is raw and not info["feet_cleaned"] and info["skating_after"] <= info["skating_before"]
    locked, info = clean_feet(raw, content, "lock", None, ExampleFeet(), slice(0, 40))
    assert locked is sliding and info["feet_cleaned"] and info["skating_after"] > info["skating_before"]
    left, info = clean_feet(raw, content, "off", None, ExampleFeet(), slice(0, 40))
    assert left is not sliding and info["feet_cleaned"] is None  # nothing asked: no cleanup, none reported left
    with pytest.raises(ValueError, match="feet: expected"):
        clean_feet(raw, content, "never", None, ExampleFeet(), slice(0, 40))


def test_the_line_tells_low_steps_as_in_the_example_from_slides():
    from dataclasses import replace

    from video2style.result import ApplyResult
    from video2style.summary import clip_line

    info = ApplyResult("c.bvh", frames=80, skating_content=0.0, skating_after=0.2, skating_low_steps=0.18,
                       swing_example=0.012)
    assert "feet slide in 0% of frames before, 20% after (18% low steps, as in the example)" in clip_line(info)
    assert "(18% low steps)" in clip_line(replace(info, swing_example=0.12))  # the example steps high: not its way
    assert "low steps" not in clip_line(replace(info, skating_low_steps=0.02))  # mostly planted feet sliding
    assert "feet left as styled" in clip_line(replace(info, feet_cleaned=False))
    assert "feet left" not in clip_line(replace(info, feet_cleaned=None))  # --feet off, --strength 0


def test_contact_config_is_typed_and_feet_config_holds_it():
    assert FeetConfig().contacts == ContactConfig() and ContactConfig().height_off > ContactConfig().height_on


def test_planted_legs_are_solved_again_where_the_hips_moved():
    locked = _standing(frames=10)
    lpos = locked.lpos.clone()
    lpos[:, 0, 0] += 0.02  # the hips moved 2 cm (spikes drawn out of them): the feet went with them
    moved = Motion(SK, locked.lrot, lpos, locked.fps)
    planted = torch.zeros(10, 2, dtype=torch.bool)
    planted[:, 0] = True  # the left foot planted, the right one not
    out = relock_legs(moved, locked, planted)
    l_ankle, r_ankle = CANONICAL.legs[0][2], CANONICAL.legs[1][2]
    got, was, went = out.global_positions(), locked.global_positions(), moved.global_positions()
    assert (got[:, l_ankle] - was[:, l_ankle]).norm(dim=-1).max() < 1e-3  # back where it was planted
    assert torch.allclose(got[:, r_ankle], went[:, r_ankle], atol=1e-5)  # a foot in swing goes with the hips
    assert torch.allclose(out.lpos, moved.lpos)  # the hips stay where they were moved


def test_a_leg_reaching_too_far_straightens_softly_and_bends_forward():
    from motioncore.cleanup import two_bone_ik
    from motioncore.kinematics import fk

    m = _standing(frames=5)
    hip, knee, ankle = CANONICAL.legs[0]
    x = torch.tensor([1.0, 0.0, 0.0])
    m.lrot[:, hip] = quat.from_axis_angle(x, torch.tensor(-0.3)).expand(5, 4)  # a knee bent forward 0.6 rad
    m.lrot[:, knee] = quat.from_axis_angle(x, torch.tensor(0.6)).expand(5, 4)
    grot, gpos = fk(m.lrot, m.lpos, SK.parents)
    full = float((gpos[0, knee] - gpos[0, hip]).norm() + (gpos[0, ankle] - gpos[0, knee]).norm())
    target = gpos[:, hip] + torch.tensor([0.0, -1.0, 0.3]) * torch.linspace(0.9, 1.1, 5)[:, None] * full / 1.044
    lrot = two_bone_ik(grot, gpos, m.lrot, SK.parents, hip, knee, ankle, target, reach=0.985)
    _, out = fk(lrot, m.lpos, SK.parents)
    reach = (out[:, ankle] - out[:, hip]).norm(dim=-1)
    assert (reach <= full - 1e-4 + 1e-6).all() and (reach[1:] >= reach[:-1] - 1e-6).all()  # no snap
    assert reach[2] < full - 3e-3  # a target at full length: the leg still a little bent (softly straightening)
    bend = out[:, knee] - 0.5 * (out[:, hip] + out[:, ankle])
    assert (bend[:, 2] > -1e-5).all() and bend[0, 2] > 0.05  # the knee bends forward, never backwards


def test_a_knee_the_planted_legs_ik_flicks_is_drawn_out_last(monkeypatch):
    import transfer.spans as spans
    from motioncore.feet import peak_acceleration
    from transfer.spans import SPIKE_LIMIT, ExampleFeet, clean_feet

    content = _standing(frames=40)  # both feet planted throughout: the held-legs rounds may not touch the legs
    knee = SK.names.index("LowerLeg_R")
    lrot = content.lrot.clone()
    lrot[20, knee] = quat.from_axis_angle(torch.tensor([1.0, 0.0, 0.0]), torch.tensor(0.6))  # one frame's flick
    flicked = Motion(SK, lrot, content.lpos.clone(), content.fps)
    monkeypatch.setattr(spans, "cleanup_feet", lambda raw, **kw: flicked)  # what a leg's IK left
    monkeypatch.setattr(spans, "relock_legs", lambda limited, cleaned, legs: limited)
    example = ExampleFeet(peak_acc=5.0)
    assert peak_acceleration(flicked.global_positions(), flicked.fps) > 4 * SPIKE_LIMIT * example.peak_acc
    out, info = clean_feet(content, content, "lock", None, example, slice(0, 40))
    assert info["feet_cleaned"]
    assert peak_acceleration(out.global_positions(), out.fps) <= 1.05 * SPIKE_LIMIT * example.peak_acc
