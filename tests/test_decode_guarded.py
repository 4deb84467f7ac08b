"""The guarded decode: rotation channels where both channel sets agree, the position fit for a limb where they
disagree (the stray-limb fix of the unseen-style issue)."""
import torch

from motioncore import quat
from motioncore.ik_fit import decode_guarded, limb_chains
from motioncore.representation import FEATURES, decode, encode
from motioncore.skeleton import CANONICAL
from testkit.motions import random_motion

SK = CANONICAL.skeleton


def test_limb_chains_come_from_the_topology():
    chains = {end: [SK.names[j] for j in chain] for end, chain in limb_chains(SK).items()}
    assert chains["Hand_L"] == ["Shoulder_L", "UpperArm_L", "LowerArm_L"]
    assert chains["Toes_R"] == ["UpperLeg_R", "LowerLeg_R", "Foot_R"]
    assert chains["Head"] == ["Neck"]
    assert len(chains) == 5


def test_agreeing_channels_give_the_rotation_decode():
    feats = encode(random_motion(seconds=3.0))
    a, b = decode(feats), decode_guarded(feats, CANONICAL.fps)
    assert torch.allclose(a.global_positions(), b.global_positions(), atol=1e-4)


def test_a_limb_whose_rotations_disagree_follows_the_positions():
    motion = random_motion(seconds=3.0, seed=1)
    feats = encode(motion)
    bad = feats.clone()
    arm = SK.index("UpperArm_L")
    rot = FEATURES.rotations
    turned = quat.mul(motion.lrot[:, arm], quat.from_axis_angle(torch.tensor([0.0, 0, 1.0]), torch.tensor(1.5)))
    bad[:, rot.start + 6 * arm:rot.start + 6 * arm + 6] = quat.to_6d(turned)  # the arm's rotation swung by 86 deg
    hand, wrist_r = SK.index("Hand_L"), SK.index("Hand_R")
    def rel(g):  # hips-relative, so the integrated root path does not enter
        return g - g[:, :1]

    truth = rel(decode(feats).global_positions())
    by_rot = rel(decode(bad).global_positions())
    guarded = rel(decode_guarded(bad, CANONICAL.fps).global_positions())
    assert (by_rot[:, hand] - truth[:, hand]).norm(dim=-1).mean() > 0.15  # the rotation decode swings the hand away
    assert (guarded[:, hand] - truth[:, hand]).norm(dim=-1).mean() < 0.03  # the guard puts it where positions say
    assert torch.allclose(guarded[:, wrist_r], by_rot[:, wrist_r], atol=1e-4)  # the other limbs untouched


def test_with_a_reference_the_smaller_change_wins():
    motion = random_motion(seconds=3.0, seed=2)
    feats = encode(motion)
    arm, hand = SK.index("UpperArm_L"), SK.index("Hand_L")
    rot, pos = FEATURES.rotations, FEATURES.positions
    swung = feats.clone()  # rotations swing the arm; positions keep it: the positions are the smaller change
    turned = quat.mul(motion.lrot[:, arm], quat.from_axis_angle(torch.tensor([0.0, 0, 1.0]), torch.tensor(1.5)))
    swung[:, rot.start + 6 * arm:rot.start + 6 * arm + 6] = quat.to_6d(turned)
    moved = feats.clone()  # positions drop the hand 60 cm; rotations keep it: the rotations are the smaller change
    y = pos.start + 3 * (hand - 1) + 1
    moved[:, y] -= 0.6

    def rel(g):
        return g - g[:, :1]

    content = decode(feats)
    truth = rel(content.global_positions())[:, hand]
    for bad in (swung, moved):
        out = rel(decode_guarded(bad, CANONICAL.fps, reference=content).global_positions())[:, hand]
        assert (out - truth).norm(dim=-1).mean() < 0.03
    no_ref = rel(decode_guarded(moved, CANONICAL.fps).global_positions())[:, hand]
    assert (no_ref - truth).norm(dim=-1).mean() > 0.15  # without a reference the positions are followed
