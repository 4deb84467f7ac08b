"""The stray-limb guard (motioncore.limbs.guard_limbs) and its place in apply (transfer.apply.decoder)."""
import pytest
import torch

from motioncore.limbs import (
    LIMBS,
    _facing,
    allowed_stray,
    guard_limbs,
    limb_places,
    motion_limb_places,
    nearest_on_segment,
)
from motioncore.representation import encode
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion

HAND_L = LIMBS.index("Hand_L")


def _off(limb: int, offset) -> torch.Tensor:
    out = torch.zeros(len(LIMBS), 3)
    out[limb] = torch.tensor(offset)
    return out


def test_motion_places_are_the_feature_places():
    motion = random_motion(seconds=3, seed=1, amplitude=0.3)
    assert motion_limb_places(motion).shape == (len(LIMBS), 3)
    assert torch.allclose(motion_limb_places(motion), limb_places(encode(motion)), atol=1e-5)


def test_allowed_stray_is_the_identity_up_to_the_start_then_stays_under_one_and_a_half_times_it():
    s = torch.tensor([0.0, 0.05, 0.08, 0.1, 0.3, 10.0])
    got = allowed_stray(s, 0.08)
    assert torch.allclose(got[:3], s[:3])
    assert 0.08 < float(got[3]) < 0.1
    assert float(got[4]) == pytest.approx(0.08 + 0.04 * torch.tanh(torch.tensor(0.22 / 0.04)).item(), abs=1e-6)
    assert float(got[5]) <= 0.12 and bool((got[1:] >= got[:-1]).all())
    with pytest.raises(ValueError, match="start above 0"):
        allowed_stray(s, 0.0)


def test_a_hand_held_30_cm_off_the_segment_comes_back_within_the_limit_and_keeps_its_motion():
    motion = random_motion(seconds=4, seed=3, amplitude=0.3)
    places = motion_limb_places(motion)
    # content and example hold the left hand 30 cm further in (towards the body) than the result does
    content, example = places - _off(HAND_L, [0.3, 0.0, 0.0]), places - _off(HAND_L, [0.3, 0.0, 0.05])
    assert float((places - nearest_on_segment(content, example, places)).norm(dim=-1)[HAND_L]) == pytest.approx(0.3, abs=1e-4)
    out, applied = guard_limbs(motion, content, example, start=0.08)
    after = motion_limb_places(out)
    stray = (after - nearest_on_segment(content, example, after)).norm(dim=-1)
    assert float(stray[HAND_L]) <= 0.12 + 1e-3  # allowed_stray never reaches 1.5 x the start
    assert float(stray[HAND_L]) == pytest.approx(float(allowed_stray(torch.tensor(0.3), 0.08)), abs=5e-3)
    assert torch.allclose(applied[HAND_L], after[HAND_L] - places[HAND_L], atol=1e-5)
    assert applied[[i for i in range(len(LIMBS)) if i != HAND_L]].abs().max() == 0
    # only the mean moved: the hand's path in the facing frame is the old one plus one constant offset
    _, before_l = _facing(motion.global_positions(), CANONICAL)
    _, after_l = _facing(out.global_positions(), CANONICAL)
    delta = after_l[:, HAND_L] - before_l[:, HAND_L]
    assert float((delta - delta.mean(0)).norm(dim=-1).max()) < 0.01
    # the other limbs, the root and the bones are untouched
    others = [CANONICAL.skeleton.index(n) for n in ("Hand_R", "Foot_L", "Foot_R", "Head")]
    assert torch.allclose(out.global_positions()[:, others], motion.global_positions()[:, others], atol=1e-5)
    assert torch.equal(out.lpos, motion.lpos)


def test_a_stray_foot_moves_only_horizontally():
    motion = random_motion(seconds=4, seed=4, amplitude=0.2)
    places = motion_limb_places(motion)
    foot = LIMBS.index("Foot_R")
    content = places - _off(foot, [0.25, 0.0, 0.0])
    _, applied = guard_limbs(motion, content, content, start=0.08)
    assert float(applied[foot, 0]) < -0.1
    assert abs(float(applied[foot, 1])) < 0.02  # the leg's reach may lift it a little; the offset has no height


def test_a_result_on_the_segment_is_unchanged():
    motion = random_motion(seconds=3, seed=5, amplitude=0.3)
    places = motion_limb_places(motion)
    content, example = places - 0.1, places + 0.1  # every place midway between the content's and the example's
    out, applied = guard_limbs(motion, content, example, start=0.08)
    assert out is motion and applied.abs().max() == 0
    # a limb off the segment but within the start is left too
    out, applied = guard_limbs(motion, places - _off(HAND_L, [0.05, 0.0, 0.0]), places - _off(HAND_L, [0.05, 0.0, 0.0]),
                               start=0.08)
    assert out is motion and applied.abs().max() == 0


def test_shapes_are_validated():
    motion = random_motion(seconds=2, seed=6)
    places = motion_limb_places(motion)
    with pytest.raises(ValueError, match=r"expected places \(4, 3\)"):
        guard_limbs(motion, places[:3], places, start=0.08)
    with pytest.raises(ValueError, match=r"expected places \(4, 3\)"):
        guard_limbs(motion, places, places.flatten(), start=0.08)
    with pytest.raises(ValueError, match="expected a, b, p"):
        nearest_on_segment(places, places[:2], places)
    with pytest.raises(ValueError, match="expected raw features"):
        limb_places(encode(motion)[:, :10])
    from testkit.motions import bandai_like_skeleton

    other = bandai_like_skeleton()
    with pytest.raises(ValueError, match="canonical skeleton"):
        motion_limb_places(type(motion)(other, torch.zeros(2, other.num_joints, 4), torch.zeros(2, other.num_joints, 3), 20.0))


def test_apply_guards_the_decoded_result_only_when_the_config_says_so():
    from dataclasses import replace

    from motioncore.motion import Motion
    from motioncore.representation import FEATURES, decode
    from transfer.apply import decoder, guard_stray_limbs
    from transfer.style_config import ApplyConfig

    result = random_motion(seconds=3, seed=7, amplitude=0.3)
    feats = encode(result)
    lowered = result.lpos.clone()
    lowered[:, 0, 1] -= 0.3
    content = Motion(result.skeleton, result.lrot, lowered, result.fps)  # every place 30 cm lower than the result's
    example = feats.clone()
    example[:, FEATURES.positions] -= torch.tensor([0.0, 0.3, 0.0]).repeat(CANONICAL.num_joints - 1)
    off = ApplyConfig(limb_guard=0.0, decode="rotations")
    assert guard_stray_limbs(result, content, example, off) is result
    assert decoder(off, reference=content, example=example) is decode  # off: the plain decode
    on = replace(off, limb_guard=0.08)
    assert decoder(on, reference=content) is decode  # no example (a style file without one): nothing to guard

    def stray(m):
        p = motion_limb_places(m)
        return (p - nearest_on_segment(motion_limb_places(content), limb_places(example), p)).norm(dim=-1)

    assert float(stray(decode(feats)).min()) == pytest.approx(0.3, abs=1e-3)
    guarded = decoder(on, reference=content, example=example)(feats, 20.0)
    assert float(stray(guarded)[:2].max()) < 0.125  # the hands drawn back down
    assert float(stray(guarded)[2:].min()) == pytest.approx(0.3, abs=0.02)  # the feet are not lowered into the floor
    with pytest.raises(ValueError, match="expected a content of"):
        guard_stray_limbs(result, content.slice(0, 10), example, on)


def test_limb_guard_is_a_validated_apply_field_and_old_style_files_get_the_default():
    from transfer.style_config import (
        APPLY_FIELDS,
        LEARN_FIELDS,
        ApplyConfig,
        check_config_value,
        split_config,
    )
    from transfer.style_file import validate_config

    assert ApplyConfig().limb_guard == pytest.approx(0.08) and "limb_guard" in APPLY_FIELDS
    assert "limb_guard" not in LEARN_FIELDS  # learning never reads it
    validate_config({"limb_guard": 0.0})
    validate_config({"limb_guard": 0.1})
    assert split_config(validate_config({"decode": "guarded"}))[1].limb_guard == ApplyConfig.limb_guard  # a file without it
    for bad in (-0.1, 1.5, float("nan"), "on", True):
        with pytest.raises(ValueError, match="limb_guard"):
            validate_config({"limb_guard": bad})
    with pytest.raises(ValueError, match="from 0.0 to 1.0"):
        check_config_value("limb_guard", 2.0)


def test_joint_channels_are_the_joints_positions_then_rotations():
    from motioncore.representation import FEATURES

    assert FEATURES.joint_channels([0]) == list(range(FEATURES.rotations.start, FEATURES.rotations.start + 6))
    hand = CANONICAL.skeleton.index("Hand_L")
    ch = FEATURES.joint_channels([hand])
    assert ch[:3] == [FEATURES.positions.start + 3 * (hand - 1) + k for k in range(3)]
    assert ch[3:] == [FEATURES.rotations.start + 6 * hand + k for k in range(6)]
    with pytest.raises(ValueError, match="expected joints in"):
        FEATURES.joint_channels([CANONICAL.num_joints])


def _hands_raised(feats: torch.Tensor, side: str, lift: float, frames: slice) -> torch.Tensor:
    """``feats`` with one hand's position channel ``lift`` metres higher on ``frames``."""
    from motioncore.representation import FEATURES

    out = feats.clone()
    hand = CANONICAL.skeleton.index(f"Hand_{side}")
    out[frames, FEATURES.joint_channels([hand])[1]] += lift  # its height
    return out


def test_hand_reach_is_zero_against_itself_and_the_lift_against_a_raised_copy():
    from motioncore.limbs import hand_reach

    feats = encode(random_motion(seconds=3, seed=8, amplitude=0.2))
    assert torch.allclose(hand_reach(feats, feats), torch.zeros(feats.shape[0], 2), atol=1e-5)
    raised = _hands_raised(feats, "L", 2.0, slice(None))  # far above anything the example does
    reach = hand_reach(raised, feats)
    assert float(reach[:, 0].min()) > 1.5 and float(reach[:, 1].max()) < 1e-5
    with pytest.raises(ValueError, match="expected example raw features"):
        hand_reach(feats, feats[:, :10])


def test_an_arm_doing_what_the_example_never_does_keeps_the_content_and_the_rest_keeps_the_style():
    from motioncore.representation import FEATURES
    from transfer.posture import ARM_JOINTS, arm_gate, gate_arms

    example = encode(random_motion(seconds=4, seed=9, amplitude=0.2))
    content = _hands_raised(example, "R", 2.0, slice(25, 60))  # the right hand far up for 1.75 s
    w = arm_gate(content, example, 0.3)
    assert w.shape == (content.shape[0], 2)
    assert torch.allclose(w[:, 0], torch.ones(content.shape[0]))  # the left hand: where the example holds it
    assert float(w[35:50, 1].max()) < 0.02 and float(w[:10, 1].min()) > 0.99 and float(w[75:, 1].min()) > 0.99
    styled = content + 0.1 * torch.randn(content.shape, generator=torch.Generator().manual_seed(0))
    out = gate_arms(styled, content, w)
    right = FEATURES.joint_channels([CANONICAL.skeleton.index(f"{n}_R") for n in ARM_JOINTS])
    rest = [c for c in range(FEATURES.dim) if c not in right]
    assert torch.equal(out[:, rest], styled[:, rest])  # the left arm, the body and the legs keep the style
    assert torch.allclose(out[40, right], content[40, right], atol=0.01)  # the raised arm keeps the content
    assert torch.allclose(out[5, right], styled[5, right], atol=1e-4)
    with pytest.raises(ValueError, match="expected a radius above 0"):
        arm_gate(content, example, 0.0)
    with pytest.raises(ValueError, match="weights"):
        gate_arms(styled, content, w[:, :1])


def _travelling(feats: torch.Tensor, speed: float) -> torch.Tensor:
    """Raw features ``(T, D)`` whose root moves forward at ``speed`` m/s (the rest as it is)."""
    from motioncore.representation import FEATURES

    out = feats.clone()
    out[:, FEATURES.root_lvel] = torch.tensor([0.0, speed / CANONICAL.fps])
    return out


def test_a_travelling_examples_style_moves_an_arm_of_a_clip_done_in_place_only_by_its_posture():
    from motioncore.representation import FEATURES
    from transfer.posture import (
        ARM_JOINTS,
        arm_motion_share,
        ground_speed,
        keep_arm_motion,
        posture_channels,
    )
    from transfer.style_losses import STAT_CHANNELS

    base = encode(random_motion(seconds=4, seed=9, amplitude=0.2))
    walk, wave = _travelling(base, 1.2), _travelling(base, 0.03)
    assert ground_speed(walk) == pytest.approx(1.2, rel=1e-5)
    assert arm_motion_share(wave, walk, 0.5) == pytest.approx(0.03 / 0.6, rel=1e-4)
    assert arm_motion_share(_travelling(base, 0.9), walk, 0.5) == 1.0  # a slower walk: all of it
    assert arm_motion_share(walk, wave, 0.5) == 1.0  # an example done in place: its arms' motion is the style
    gen = torch.Generator().manual_seed(0)
    styled = wave + 0.3 + 0.1 * torch.randn(wave.shape, generator=gen)  # a held offset and a moving change
    out = keep_arm_motion(styled, wave, 0.0)
    arms = FEATURES.joint_channels([CANONICAL.skeleton.index(f"{n}_{s}") for s in "LR" for n in ARM_JOINTS])
    rest = [c for c in range(FEATURES.dim) if c not in arms]
    assert torch.equal(out[:, rest], styled[:, rest])  # the body and legs keep all of the style
    change = out[:, arms] - wave[:, arms]
    assert torch.allclose(change, change.mean(0, keepdim=True).expand_as(change), atol=1e-5)  # held, not moved
    assert torch.allclose(change.mean(0), (styled - wave)[:, arms].mean(0), atol=1e-5)  # where the style holds it
    full = (styled - wave)[:, arms]
    half = keep_arm_motion(styled, wave, 0.5)[:, arms] - wave[:, arms]
    assert torch.allclose(half - half.mean(0), 0.5 * (full - full.mean(0)), atol=1e-5)  # half of how it moves
    assert torch.equal(keep_arm_motion(styled, wave, 1.0), styled)
    held = posture_channels(torch.full((len(STAT_CHANNELS),), 0.2), FEATURES.dim, amount=0.5)
    assert float(held[FEATURES.root_lvel].abs().max()) == 0.0 and float(held[arms].min()) == pytest.approx(0.1)
    at_pose = keep_arm_motion(styled, wave, 0.0, held)[:, arms] - wave[:, arms]  # held where the example holds them
    assert torch.allclose(at_pose, torch.full_like(at_pose, 0.1), atol=1e-5)
    quarter = keep_arm_motion(styled, wave, 0.25, held)[:, arms] - wave[:, arms]
    assert torch.allclose(quarter.mean(0), 0.25 * full.mean(0) + 0.75 * 0.1, atol=1e-5)
    with pytest.raises(ValueError, match="expected a travel share above 0"):
        arm_motion_share(wave, walk, 0.0)
    with pytest.raises(ValueError, match="expected out and content"):
        keep_arm_motion(styled, wave[:10], 0.5)
    with pytest.raises(ValueError, match="expected held"):
        keep_arm_motion(styled, wave, 0.5, held[:10])


def test_a_posture_moves_each_channel_from_the_contents_mean_towards_the_examples_not_past_them():
    from motioncore.representation import FEATURES
    from transfer.posture import POSTURE_TOLERANCE, posture_between
    from transfer.style_losses import STAT_CHANNELS

    content, example = torch.zeros(50, FEATURES.dim), torch.zeros(30, FEATURES.dim)
    ch = STAT_CHANNELS
    example[:, ch[0]], example[:, ch[1]], example[:, ch[4]] = 1.0, -1.0, 1.0
    shift = torch.zeros(len(ch))
    shift[0], shift[1], shift[2], shift[3], shift[4] = 0.5, 3.0, 2.0, -0.05, 3.0
    out = posture_between(shift, content, example)
    assert out[0] == pytest.approx(0.5) and out[3] == pytest.approx(-0.05)  # towards the example, within tolerance
    assert out[1] == pytest.approx(POSTURE_TOLERANCE) and out[2] == pytest.approx(POSTURE_TOLERANCE)  # away: cut
    assert out[4] == pytest.approx(1.0 + POSTURE_TOLERANCE)  # past the example: cut there
    half = posture_between(shift, content, example, amount=0.5)  # what a half amount carries is bounded the same way
    assert 0.5 * half[2] == pytest.approx(POSTURE_TOLERANCE) and half[0] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="expected a shift"):
        posture_between(shift[:5], content, example)
    with pytest.raises(ValueError, match="expected content and example"):
        posture_between(shift, content, example[:, :10])


def test_a_neutral_pair_is_held_between_where_the_example_and_neutral_clips_hold_each_channel():
    from motioncore.representation import FEATURES
    from transfer.posture import PAIR_SPREAD, POSTURE_TOLERANCE, bound_pair
    from transfer.style_losses import STAT_CHANNELS

    ch = STAT_CHANNELS
    gen = torch.Generator().manual_seed(0)
    example = torch.randn(40, FEATURES.dim, generator=gen) * 0.1
    example[:, ch[0]] += 1.0  # the example holds channel 0 at 1
    neutral = [torch.zeros(30, FEATURES.dim) + m for m in (-0.1, 0.1)]  # neutral clips: time-means -0.1 and 0.1
    pair = torch.randn(40, FEATURES.dim, generator=gen) * 0.1
    pair[:, ch[0]] += 0.5  # between them: kept
    pair[:, ch[1]] += 3.0  # a tilt neither has: brought back to the span's edge, the motion over time kept
    pair[:, ch[2]] -= 3.0
    trajectory = [i for i in range(FEATURES.dim) if i not in set(ch.tolist())]
    pair[:, trajectory] += 5.0  # the path is the example's (inpainted): never moved
    out = bound_pair(pair, example, neutral)
    spread = PAIR_SPREAD * 0.1
    high = max(float(example[:, ch[1]].mean()), spread) + POSTURE_TOLERANCE
    low = min(float(example[:, ch[2]].mean()), -spread) - POSTURE_TOLERANCE
    assert torch.equal(out[:, ch[0]], pair[:, ch[0]]) and torch.equal(out[:, trajectory], pair[:, trajectory])
    assert float(out[:, ch[1]].mean()) == pytest.approx(high, abs=1e-5)
    assert float(out[:, ch[2]].mean()) == pytest.approx(low, abs=1e-5)
    assert torch.allclose(out[:, ch[1]] - out[:, ch[1]].mean(), pair[:, ch[1]] - pair[:, ch[1]].mean(), atol=1e-5)
    assert torch.equal(bound_pair(pair, example, []), pair)  # no neutral clips of the action: as it is
    with pytest.raises(ValueError, match="expected pair and example"):
        bound_pair(pair[:10], example, neutral)


def test_a_swung_arm_keeps_its_elbow_and_wrist_angles_and_comes_back_towards_the_segment():
    from motioncore.kinematics import fk
    from motioncore.limbs import swing_limb

    motion = random_motion(seconds=4, seed=3, amplitude=0.3)
    sk = CANONICAL.skeleton
    upper, lower, hand = sk.index("UpperArm_L"), sk.index("LowerArm_L"), sk.index("Hand_L")
    grot, gpos = fk(motion.lrot, motion.lpos, sk.parents)
    target = gpos[:, upper] + torch.tensor([0.0, -0.4, 0.1])  # a place below the shoulder, frame by frame
    lrot = swing_limb(grot, gpos, motion.lrot, sk.parents, upper, hand, target)
    changed = (lrot - motion.lrot).abs().amax(dim=(0, 2))
    assert changed[upper] > 0 and changed[[j for j in range(sk.num_joints) if j != upper]].max() == 0
    _, gpos2 = fk(lrot, motion.lpos, sk.parents)
    reach = gpos[:, hand] - gpos[:, upper]
    assert torch.allclose((gpos2[:, hand] - gpos2[:, upper]).norm(dim=-1), reach.norm(dim=-1), atol=1e-5)
    aim = torch.nn.functional.normalize(target - gpos[:, upper], dim=-1)
    assert torch.allclose(torch.nn.functional.normalize(gpos2[:, hand] - gpos2[:, upper], dim=-1), aim, atol=1e-4)

    places = motion_limb_places(motion)
    content, example = places - _off(HAND_L, [0.3, 0.0, 0.0]), places - _off(HAND_L, [0.3, 0.0, 0.05])
    out, _ = guard_limbs(motion, content, example, start=0.08, swing_hands=True)
    after = motion_limb_places(out)
    stray = (after - nearest_on_segment(content, example, after)).norm(dim=-1)
    assert float(stray[HAND_L]) < 0.2  # 0.3 before: drawn back, the reach an arm swung at the shoulder has
    assert torch.allclose(out.lrot[:, [lower, hand]], motion.lrot[:, [lower, hand]], atol=1e-6)  # normalised only
