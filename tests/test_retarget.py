import json
from pathlib import Path

import pytest
import torch

from motioncore import quat
from motioncore.bvh import read_bvh
from motioncore.kinematics import fk
from motioncore.motion import Motion, resample
from motioncore.retarget import (
    RetargetError,
    carry_edit,
    find_roles,
    from_canonical,
    load_joint_map,
    make_rig,
    place_on_floor,
    to_canonical,
)
from motioncore.skeleton import CANONICAL, Skeleton
from testkit.motions import (
    CANONICAL_NAMES_MAP,
    CMU_LIKE_ROLES,
    bandai_like_skeleton,
    cmu_like_skeleton,
    random_motion,
)

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def _round_trip_error(rig):
    """Canonical -> rig -> canonical, on a motion that does not move the roles the rig has no bone for."""
    m = random_motion(seconds=5.0, seed=21)
    m.lrot[:, [c for c, s in enumerate(rig.mapping) if s is None]] = quat.identity()
    back = to_canonical(from_canonical(m, rig), rig)
    return (back.global_positions() - m.global_positions()).norm(dim=-1).max()


def _bandai_rig():
    return make_rig(bandai_like_skeleton(), joint_map=CANONICAL_NAMES_MAP)  # its rest pose is scrambled: a map


@pytest.mark.parametrize("rig", [_bandai_rig, lambda: make_rig(cmu_like_skeleton())])
def test_canonical_to_foreign_and_back_within_1cm(rig):
    assert _round_trip_error(rig()) < 0.01


def test_joints_above_the_hips_carry_them_and_keep_their_rest_offsets():
    """Bandai's joint_Root (UE's root): the root moves so that the hips follow; offsets stay as in the file."""
    rig = _bandai_rig()
    m = random_motion(seconds=2.0, seed=3)
    out = from_canonical(m, rig)
    assert torch.allclose(out.lpos[:, 1:], rig.skeleton.offsets[1:].expand_as(out.lpos[:, 1:]))
    hips_world = out.global_positions()[:, 1]
    assert torch.allclose(hips_world * rig.scale, m.lpos[:, 0], atol=1e-4)


def test_foreign_pose_matches_canonical_pose():
    """A motion moved onto the CMU-like skeleton points each bone the same way."""
    rig = make_rig(cmu_like_skeleton())
    m = random_motion(seconds=2.0, seed=5)
    pc = m.global_positions()
    pf = from_canonical(m, rig).global_positions()
    names = CANONICAL.skeleton.names
    for bone in [("UpperArm_L", "LowerArm_L"), ("UpperLeg_R", "LowerLeg_R"), ("LowerLeg_L", "Foot_L")]:
        a, b = (names.index(n) for n in bone)
        da = torch.nn.functional.normalize(pc[:, b] - pc[:, a], dim=-1)
        fa, fb = (rig.mapping[names.index(n)] for n in bone)
        db = torch.nn.functional.normalize(pf[:, fb] - pf[:, fa], dim=-1)
        assert (da * db).sum(-1).min() > 0.999


def test_roles_come_from_geometry_not_names():
    sk = cmu_like_skeleton()
    rig = make_rig(sk)
    assert rig.map_name == "auto" and rig.humanoid.names(sk) == CMU_LIKE_ROLES
    odd = Skeleton(tuple(f"bone{i}" for i in range(sk.num_joints)), sk.parents, sk.offsets, sk.end_sites)
    joints, how, _ = find_roles(odd)
    assert how == "auto" and joints == rig.mapping  # no name says anything; feet show which way is forward


def test_partial_joint_map_overrides_only_what_it_names(tmp_path):
    sk = cmu_like_skeleton()
    path = tmp_path / "map.json"
    path.write_text(json.dumps({"Neck": "Neck1", "Shoulder_L": None}))
    rig = make_rig(sk, joint_map=load_joint_map(path))
    names = rig.humanoid.names(sk) | {"Neck": "Neck1", "Shoulder_L": None}
    assert rig.map_name == "auto+user"
    assert {r: None if j is None else sk.names[j] for r, j in zip(CANONICAL.skeleton.names, rig.mapping)} == names
    assert _round_trip_error(rig) < 0.01  # a role without a bone (no clavicle) still round-trips
    with pytest.raises(RetargetError, match="no such joint"):
        make_rig(sk, joint_map={"Head": "Skull"})
    with pytest.raises(RetargetError, match="two roles"):
        make_rig(sk, joint_map={"Head": "Neck"})
    path.write_text(json.dumps({"Hips": None}))
    with pytest.raises(RetargetError, match="need a joint"):
        load_joint_map(path)


def test_not_a_humanoid_is_one_line_pointing_at_the_skeleton_command():
    chain = Skeleton(tuple(f"b{i}" for i in range(6)), (-1, 0, 1, 2, 3, 4), torch.tensor([[0, 0, 0]] + [[0, 0.2, 0]] * 5))
    with pytest.raises(RetargetError) as e:
        make_rig(chain, source="snake.bvh")
    msg = str(e.value)
    assert msg.startswith("snake.bvh: not a humanoid") and "skeleton snake.bvh --write-map" in msg and "\n" not in msg
    full = dict(CANONICAL_NAMES_MAP)
    with pytest.raises(RetargetError, match="no such joint"):
        make_rig(chain, joint_map=full)


def _with_fingers_moving(motion: Motion, rig, seed: int = 0) -> Motion:
    """``motion`` with random rotations on every joint that has no role (fingers, helpers)."""
    g = torch.Generator().manual_seed(seed)
    lrot = motion.lrot.clone()
    for j in range(motion.skeleton.num_joints):
        if j not in rig.mapping and j > 0:
            axis = torch.randn(3, generator=g)
            angle = 0.5 * torch.sin(torch.arange(motion.num_frames) / 7.0 + j)
            lrot[:, j] = quat.mul(lrot[:, j], quat.from_axis_angle(axis / axis.norm(), angle))
    return Motion(motion.skeleton, lrot, motion.lpos, motion.fps)


def _edit(motion: Motion, seed: int = 1) -> Motion:
    """A canonical 'style': extra smooth rotations on every joint, a sideways drift of the root."""
    extra = random_motion(seconds=motion.duration, fps=motion.fps, seed=seed, amplitude=0.2)
    lrot = quat.mul(motion.lrot, extra.lrot[: motion.num_frames])
    lpos = motion.lpos.clone()
    lpos[:, 0, 0] += torch.linspace(0, 0.3, motion.num_frames)
    return Motion(motion.skeleton, lrot, lpos, motion.fps)


def test_carry_edit_of_no_change_is_the_original():
    rig = make_rig(cmu_like_skeleton())
    original = _with_fingers_moving(resample(from_canonical(random_motion(seconds=3.0, seed=2), rig), 30.0), rig)
    before = place_on_floor(to_canonical(resample(original, 20.0), rig))
    out = carry_edit(original, before, before, rig)
    assert out.num_frames == original.num_frames and out.fps == original.fps
    assert torch.allclose(out.global_positions(), original.global_positions(), atol=1e-4)
    assert (quat.angle(quat.mul(quat.inv(out.lrot), original.lrot)) < 1e-3).all()


def test_carry_edit_moves_bones_like_the_edit_keeps_twist_and_fingers():
    rig = make_rig(cmu_like_skeleton())
    original = _with_fingers_moving(from_canonical(random_motion(seconds=3.0, seed=2), rig), rig)
    before = to_canonical(original, rig)
    after = _edit(before)
    out = carry_edit(original, before, after, rig)
    back, pos_a = to_canonical(out, rig).global_positions(), after.global_positions()
    names = CANONICAL.skeleton.names
    for a, b in [("Hips", "Spine"), ("UpperArm_L", "LowerArm_L"), ("LowerArm_R", "Hand_R"), ("UpperLeg_L", "LowerLeg_L"),
                 ("LowerLeg_R", "Foot_R"), ("Spine", "Chest"), ("Neck", "Head")]:  # bones point as edited
        ia, ib = names.index(a), names.index(b)
        cos = torch.nn.functional.cosine_similarity(back[:, ib] - back[:, ia], pos_a[:, ib] - pos_a[:, ia], dim=-1)
        # Neck -> Head runs through an extra joint (Neck1) that keeps its own rotation: within 3 degrees
        assert float(cos.min()) > (0.9986 if a == "Neck" else 1 - 1e-5), (a, b)
    extras = [j for j in range(1, rig.skeleton.num_joints) if j not in rig.mapping]
    assert torch.allclose(out.lrot[:, extras].abs(), original.lrot[:, extras].abs(), atol=1e-5)  # fingers as they were
    # twist about each limb bone: the world change of a mapped limb joint is a pure swing about its bone
    grot_o, gpos_o = fk(original.lrot.double(), original.lpos.double(), original.skeleton.parents)
    grot_n, _ = fk(out.lrot.double(), out.lpos.double(), out.skeleton.parents)
    for a, b in [("UpperArm_L", "LowerArm_L"), ("LowerArm_R", "Hand_R"), ("UpperLeg_L", "LowerLeg_L"), ("Spine", "Chest")]:
        ja, jb = rig.mapping[names.index(a)], rig.mapping[names.index(b)]
        axis = torch.nn.functional.normalize(gpos_o[:, jb] - gpos_o[:, ja], dim=-1)
        d = quat.mul(grot_n[:, ja], quat.inv(grot_o[:, ja]))
        twist = 2 * torch.atan2((d[:, 1:] * axis).sum(-1).abs(), d[:, 0].abs())
        assert float(twist.max()) < 1e-3, a


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data not present (real-skeleton retarget checks)")
@pytest.mark.parametrize("name,chest", [("xia_test/old_13_000.bvh", "Spine1"), ("bvh_misc/fair1_dab.bvh", "Spine3")])
def test_real_skeletons_round_trip(name, chest):
    src, _ = read_bvh(SHARED / name)
    rig = make_rig(src.skeleton, src, source=name)
    roles = rig.humanoid.names(src.skeleton)
    assert roles["Chest"] == chest and roles["Hand_L"] == "LeftHand" and roles["UpperArm_R"] == "RightArm"
    assert roles["UpperLeg_L"] == "LeftUpLeg" and roles["Toes_R"] == "RightToeBase" and roles["Head"] == "Head"
    assert _round_trip_error(rig) < 0.01
    canon = to_canonical(src, rig)
    head_up = (canon.global_positions()[:, 4, 1] - canon.global_positions()[:, 0, 1]).mean()
    assert head_up > 0.3  # Y-up after retargeting, whatever the source's up axis


def test_bad_joint_map_files_are_one_line_naming_the_file(tmp_path):
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\xff\xfe\x00garbage\x80")
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 50_000 + "]" * 50_000)
    big = tmp_path / "big.json"
    big.write_text('{"Hips": "' + "x" * 70_000 + '"}')
    for path in (binary, deep, big):
        with pytest.raises(RetargetError) as e:
            load_joint_map(path)
        assert str(e.value).startswith(f"{path}: cannot read joint map") and "\n" not in str(e.value)
    bom = tmp_path / "bom.json"
    bom.write_text('\ufeff{"Hips": "pelvis"}', encoding="utf-8")
    assert load_joint_map(bom) == {"Hips": "pelvis"}
