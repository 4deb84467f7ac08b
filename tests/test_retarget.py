import json
from pathlib import Path

import pytest
import torch

from motioncore.bvh import read_bvh
from motioncore.retarget import (
    RetargetError,
    from_canonical,
    load_joint_map,
    make_rig,
    match_joint_map,
    to_canonical,
)
from motioncore.skeleton import CANONICAL, Skeleton
from tests.helpers import bandai_like_skeleton, cmu_like_skeleton, random_motion

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def _round_trip_error(rig):
    m = random_motion(seconds=5.0, seed=21)
    back = to_canonical(from_canonical(m, rig), rig)
    return (back.global_positions() - m.global_positions()).norm(dim=-1).max()


@pytest.mark.parametrize("make", [bandai_like_skeleton, cmu_like_skeleton])
def test_canonical_to_foreign_and_back_within_1cm(make):
    rig = make_rig(make())
    assert _round_trip_error(rig) < 0.01


def test_bandai_like_joint_root_stays_at_rest_and_hips_follow():
    rig = make_rig(bandai_like_skeleton())
    m = random_motion(seconds=2.0, seed=3)
    out = from_canonical(m, rig)
    assert torch.allclose(out.lpos[:, 0], torch.zeros(3))
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


def test_mixamo_prefixes_are_recognised():
    sk = cmu_like_skeleton()
    rename = {"Spine": "Spine1", "Spine1": "Spine2"}
    renamed = tuple(f"mixamorig:{rename.get(n, n)}" for n in sk.names)
    name, _ = match_joint_map(Skeleton(renamed, sk.parents, sk.offsets))
    assert name == "mixamo"


def test_unknown_skeleton_lists_missing_joints_and_how_to_fix(tmp_path):
    sk = cmu_like_skeleton()
    odd = Skeleton(tuple(f"bone{i}" for i in range(sk.num_joints)), sk.parents, sk.offsets)
    with pytest.raises(RetargetError) as e:
        make_rig(odd, source="odd.bvh")
    msg = str(e.value)
    assert msg.startswith("odd.bvh:") and "Hips" in msg and "--joint-map" in msg
    # a user map fixes it
    _, idx = match_joint_map(sk)
    user = {canon: odd.names[i] for canon, i in zip(CANONICAL.skeleton.names, idx)}
    path = tmp_path / "map.json"
    path.write_text(json.dumps(user))
    rig = make_rig(odd, joint_map=load_joint_map(path))
    assert rig.map_name == "user" and _round_trip_error(rig) < 0.01


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data not present (real-skeleton retarget checks)")
@pytest.mark.parametrize("name,expected", [("xia_test/old_13_000.bvh", "cmu"), ("bvh_misc/fair1_dab.bvh", "animated_drawings")])
def test_real_skeletons_round_trip(name, expected):
    src, _ = read_bvh(SHARED / name)
    rig = make_rig(src.skeleton, src, source=name)
    assert rig.map_name == expected
    assert _round_trip_error(rig) < 0.01
    canon = to_canonical(src, rig)
    head_up = (canon.global_positions()[:, 4, 1] - canon.global_positions()[:, 0, 1]).mean()
    assert head_up > 0.3  # Y-up after retargeting, whatever the source's up axis


def test_bad_joint_map_files_are_one_line_naming_the_file(tmp_path):
    from motioncore.retarget import RetargetError, load_joint_map

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
