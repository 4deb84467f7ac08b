"""Automatic humanoid mapping on clips that never show a standing figure (testkit/rig_poses.py), in every
convention of testkit/rig_corpus.py; the non-humanoids stay refused; errors name the ambiguous roles."""
import pytest
import torch

from motioncore import quat
from motioncore.humanoid import NotHumanoidError, find_humanoid, up_axis
from motioncore.kinematics import fk
from motioncore.retarget import RetargetError, make_rig, up_basis
from motioncore.skeleton import Skeleton
from testkit.motions import CANONICAL_NAMES_MAP, bandai_like_skeleton
from testkit.rig_corpus import CASES, DISPUTED_CASES, NON_HUMANOID, case, rest_motion
from testkit.rig_poses import POSES, posed_motion

ALL = CASES + DISPUTED_CASES
UP = {"Y": "+Y", "Z": "+Z"}


def _anonymous(sk: Skeleton, ends: bool = True) -> Skeleton:
    return Skeleton(tuple(f"j{i}" for i in range(sk.num_joints)), sk.parents, sk.offsets,
                    sk.end_sites if ends else {})


def test_the_pose_corpus_holds_the_poses_the_issue_lists():
    assert set(POSES) >= {"arms_folded", "hands_on_hips", "arms_overhead", "hands_behind_back", "deep_crouch",
                          "sitting", "run_one_hand_high", "lying_down"}


@pytest.mark.parametrize("pose", ["arms_folded", "deep_crouch", "lying_down", "run_one_hand_high"])
def test_posed_clips_hold_their_pose(pose):
    """The generator does what it says (Bandai's layout, rest pose laid along X, cm): a check of the corpus."""
    c = case("bandai")
    m = posed_motion(c, pose, "bones_x")
    pos = m.global_positions()
    at = {r: pos[:, c.skeleton.index(n)] for r, n in c.expected.items() if n is not None}
    rest = rest_motion(m.skeleton, 1).global_positions()[0]
    assert float((rest[c.skeleton.index("Head")] - rest[c.skeleton.index("Hips")])[0]) > 0.4  # rest: along +X
    if pose == "arms_folded":  # both hands at chest height, about 10 cm from the midline, the whole clip
        for s in ("L", "R"):
            assert (at[f"Hand_{s}"][:, 1] - at["Chest"][:, 1]).abs().max() < 0.15
            side = (at[f"Hand_{s}"] - at["Hips"])[:, [0, 2]].norm(dim=-1) - (at["Chest"] - at["Hips"])[:, [0, 2]].norm(dim=-1)
            assert float(side.abs().max()) < 0.25
    elif pose == "deep_crouch":
        assert float(at["Hips"][:, 1].max()) < 0.5 and float((at["Head"][:, 1] - at["Hips"][:, 1]).min()) > 0.3
    elif pose == "lying_down":
        assert float((at["Head"] - at["Hips"])[:, 1].abs().max()) < 0.1  # head level with the hips
    else:
        assert float((at["Hand_R"][:, 1] - at["Head"][:, 1]).min()) > 0.0  # one hand above the head


@pytest.mark.slow
@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_every_role_found_in_every_pose_when_the_frames_decide(c):
    """The rest pose lies along X (Bandai's), so the pose is read from frames: the geometry must decide."""
    for pose in POSES:
        m = posed_motion(c, pose, "bones_x")
        found = find_humanoid(m.skeleton, m.lrot, m.lpos)
        assert found.names(m.skeleton) == c.expected, pose
        assert found.pose.startswith("frame"), (pose, found.pose)
        if pose != "lying_down":
            assert found.up == UP[c.up], pose


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_every_role_found_in_every_pose_when_the_rest_pose_stands(c):
    for pose in POSES:
        m = posed_motion(c, pose, "file")
        found = find_humanoid(m.skeleton, m.lrot, m.lpos)
        assert found.names(m.skeleton) == c.expected and found.pose == "rest pose", pose
        if pose != "lying_down":
            assert found.up == UP[c.up], pose


@pytest.mark.parametrize("name", ["bandai", "mixamo", "ue5", "smpl", "biped"])
def test_names_do_not_decide_in_unusual_poses(name):
    """Without joint names the geometry of the frames still finds every role (the head of a neck chain aside)."""
    c = case(name)
    for pose in ("arms_folded", "hands_behind_back", "deep_crouch", "run_one_hand_high", "lying_down"):
        m = posed_motion(c, pose, "bones_x")
        anon = _anonymous(m.skeleton)
        got = find_humanoid(anon, m.lrot, m.lpos).names(anon)
        wrong = {r for r, n in c.expected.items() if got[r] != (None if n is None else f"j{c.skeleton.index(n)}")}
        assert wrong <= {"Head"}, (pose, wrong)


@pytest.mark.parametrize("name", sorted(NON_HUMANOID))
def test_non_humanoids_stay_refused_with_a_clip(name):
    sk = NON_HUMANOID[name]
    m = rest_motion(sk, frames=20)
    m.lrot[:, 1:] = quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]), 0.2 * torch.sin(torch.arange(20) / 3.0))[:, None]
    with pytest.raises(NotHumanoidError) as e:
        find_humanoid(sk, m.lrot, m.lpos)
    assert ("quadruped" in str(e.value)) == (name == "quadruped")
    assert "not found" in str(e.value) and "\n" not in str(e.value)


def test_a_person_is_never_called_a_quadruped():
    """Rest pose laid along X and nothing else to read, names gone: refused, naming roles, no quadruped."""
    for c in (case("bandai"), case("mixamo"), case("hik")):
        m = posed_motion(c, "arms_folded", "bones_x")
        with pytest.raises(NotHumanoidError) as e:
            find_humanoid(_anonymous(m.skeleton))
        msg = str(e.value)
        assert "quadruped" not in msg and "Hips" in msg and "Chest" in msg and "legs" in msg


def test_an_ambiguous_side_names_the_roles_and_why():
    """No toe joints, no foot End Sites, no side in the names: which leg is left cannot be told."""
    c = case("no_toes")
    m = posed_motion(c, "sitting", "bones_x")
    with pytest.raises(NotHumanoidError) as e:
        find_humanoid(_anonymous(m.skeleton, ends=False), m.lrot, m.lpos)
    msg = str(e.value)
    assert "left leg from the right" in msg and "UpperLeg" in msg and "frames read" in msg
    assert "quadruped" not in msg


def test_names_of_a_known_convention_decide_where_the_geometry_cannot():
    sk = bandai_like_skeleton()  # rest pose scrambled at random, no clip: nothing to read
    found = find_humanoid(sk)
    assert found.pose == "joint names" and found.names(sk) == CANONICAL_NAMES_MAP
    assert "Bandai" in found.how[0] and found.up == "+Y"
    with pytest.raises(NotHumanoidError, match="not found") as e:
        find_humanoid(_anonymous(sk))
    assert "quadruped" not in str(e.value)


def test_the_up_axis_is_decided_once_and_the_rig_and_preview_use_it():
    from video2style.preview import _original_panel, _up_basis

    c = case("bandai")
    m = posed_motion(c, "arms_folded", "bones_x", frames=40)
    rig = make_rig(m.skeleton, m)
    _, gpos = fk(m.lrot, m.lpos, m.skeleton.parents)
    assert rig.humanoid.up == up_axis(gpos, rig.humanoid.joint("Hips"), rig.humanoid.joint("Head")) == "+Y"
    assert torch.allclose(rig.basis, up_basis(rig.humanoid.up))
    assert torch.allclose(_up_basis(m, None, "clip.bvh")[0], rig.basis)
    panel = _original_panel(m, None, "clip", "clip.bvh")  # plain preview: the figure stands
    names = list(panel.names)
    up = panel.positions[:, names.index("Head"), 1] - panel.positions[:, names.index("Hips"), 1]
    assert float(up.min()) > 0.4
    # Z-up convention: the rig turns +Z to +Y
    z = posed_motion(case("ue5"), "deep_crouch", "bones_x")
    zrig = make_rig(z.skeleton, z)
    assert zrig.humanoid.up == "+Z" and torch.allclose(zrig.basis, up_basis("+Z"))


def test_make_rig_on_a_refused_person_is_one_line_without_quadruped():
    m = posed_motion(case("mixamo"), "arms_folded", "bones_x")
    with pytest.raises(RetargetError) as e:
        make_rig(_anonymous(m.skeleton), source="proud.bvh")
    msg = str(e.value)
    assert msg.startswith("proud.bvh: not a humanoid") and "\n" not in msg and "quadruped" not in msg


def test_clip_shapes_are_checked():
    c = case("bandai")
    m = posed_motion(c, "sitting", "bones_x")
    with pytest.raises(ValueError, match="expected lrot"):
        find_humanoid(m.skeleton, m.lrot[:, :3], m.lpos)
