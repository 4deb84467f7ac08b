"""Smoke tests of the synthetic rig corpus itself (testkit/rig_corpus.py)."""
import re

import pytest
import torch

from motioncore.bvh import format_bvh, parse_bvh
from motioncore.kinematics import rest_positions
from motioncore.skeleton import Skeleton
from testkit.rig_corpus import (
    CASES,
    DISPUTED_CASES,
    NON_HUMANOID,
    ROLES,
    TWO_ROOTS_BVH,
    case,
    rest_motion,
)

REQUIRED = ("mixamo", "ue4", "ue5", "unity", "cmu_hips", "cmu_lhipjoint", "rokoko", "biped", "rigify", "smpl",
            "smplx", "vrm", "hik", "bandai", "animated_drawings")
ALL = CASES + DISPUTED_CASES
DISPUTED = {c.name for c in DISPUTED_CASES}
# parse_bvh reads these words as keywords in any case, so a joint named "root" comes back as "ROOT"


def _ancestors(sk: Skeleton, j: int) -> list[int]:
    out = []
    while j != -1:
        out.append(j)
        j = sk.parents[j]
    return out  # j itself first, root last


def _lca(sk: Skeleton, a: int, b: int) -> int:
    anc_b = set(_ancestors(sk, b))
    return next(j for j in _ancestors(sk, a) if j in anc_b)


def _up_forward(c):
    """(up axis index, forward unit vector) in the rig's world axes."""
    return (1, torch.tensor([0.0, 0.0, 1.0])) if c.up == "Y" else (2, torch.tensor([0.0, -1.0, 0.0]))


def test_case_list_covers_the_conventions():
    names = [c.name for c in ALL]
    assert len(set(names)) == len(names)
    assert set(REQUIRED) <= {c.name for c in CASES} and len(CASES) >= 12
    assert {c.up for c in CASES} == {"Y", "Z"}
    assert {c.rest for c in CASES} == {"T", "A"}
    assert {c.units for c in CASES} == {"m", "cm", "in"}
    assert any(c.expected["Shoulder_L"] is None for c in CASES)
    assert any(c.expected["Toes_L"] is None for c in CASES)
    assert case("smpl").expected["UpperArm_L"] == "left_shoulder"
    with pytest.raises(KeyError):
        case("nope")


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_case_is_well_formed(c):
    sk = c.skeleton
    assert tuple(c.expected) == ROLES
    assert sk.offsets.dtype == torch.float32 and torch.isfinite(sk.offsets).all()
    for role, name in c.expected.items():
        assert name is None or name in sk.names, (role, name)
    mapped = [n for n in c.expected.values() if n is not None]
    assert len(set(mapped)) == len(mapped)
    assert len(c.layout.channels) == sk.num_joints
    assert c.layout.channels[0][:3] == ("Xposition", "Yposition", "Zposition")
    assert all(sum(ch.endswith("rotation") for ch in chans) == 3 for chans in c.layout.channels)
    assert c.layout.scale == {"m": 1.0, "cm": 0.01, "in": 0.0254}[c.units]


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_expected_mapping_follows_the_hierarchy(c):
    sk = c.skeleton
    ix = {r: (None if n is None else sk.index(n)) for r, n in c.expected.items()}
    pos = rest_positions(sk.offsets, sk.parents)

    def is_ancestor(a, b):  # a strictly above b
        return a != b and a in _ancestors(sk, b)

    assert _lca(sk, ix["UpperLeg_L"], ix["UpperLeg_R"]) == ix["Hips"]
    if c.name not in DISPUTED:
        assert _lca(sk, ix["Hand_L"], ix["Hand_R"]) == ix["Chest"]
    else:  # the disputed cases are exactly those where the plain LCA rule misses the chest
        assert _lca(sk, ix["Hand_L"], ix["Hand_R"]) != ix["Chest"]
    assert is_ancestor(ix["Hips"], ix["Chest"]) and is_ancestor(ix["Chest"], ix["Neck"])
    assert sk.parents[ix["Neck"]] == ix["Chest"] and is_ancestor(ix["Neck"], ix["Head"])
    if ix["Spine"] is not None:
        assert is_ancestor(ix["Hips"], ix["Spine"]) and is_ancestor(ix["Spine"], ix["Chest"])
        below = [j for j in _ancestors(sk, ix["Spine"])[1:] if is_ancestor(ix["Hips"], j)]
        assert all((pos[j] - pos[ix["Hips"]]).norm() < 1e-6 for j in below)  # nothing away from Hips before Spine
        assert (pos[ix["Spine"]] - pos[ix["Hips"]]).norm() > 0.02
    for s in ("_L", "_R"):
        shoulder, upper, lower, hand = (ix[r + s] for r in ("Shoulder", "UpperArm", "LowerArm", "Hand"))
        if shoulder is None:
            assert sk.parents[upper] == ix["Chest"]
        else:
            assert is_ancestor(ix["Chest"], shoulder) and is_ancestor(shoulder, upper)
            assert c.name in DISPUTED or sk.parents[shoulder] == ix["Chest"]
        assert is_ancestor(upper, lower) and is_ancestor(lower, hand)
        thigh, knee, foot, toes = (ix[r + s] for r in ("UpperLeg", "LowerLeg", "Foot", "Toes"))
        assert is_ancestor(thigh, knee) and is_ancestor(knee, foot)
        assert toes is None or is_ancestor(foot, toes)
        between = [j for j in _ancestors(sk, thigh)[1:] if is_ancestor(ix["Hips"], j)]
        assert all((pos[j] - pos[ix["Hips"]]).norm() < 1e-6 for j in between)
        assert (pos[thigh] - pos[ix["Hips"]]).norm() > 0.05


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_rest_geometry_matches_the_stated_axes_and_pose(c):
    sk = c.skeleton
    pos = rest_positions(sk.offsets, sk.parents)
    at = {r: pos[sk.index(n)] for r, n in c.expected.items() if n is not None}
    up, fwd = _up_forward(c)
    assert at["Head"][up] > at["Chest"][up] > at["Hips"][up] > at["LowerLeg_L"][up] > at["Foot_L"][up]
    assert 0.8 < float(at["Hips"][up] - at["Foot_L"][up]) < 0.95  # legs about 0.87 m
    for s, sign in (("_L", 1), ("_R", -1)):
        assert sign * at["Foot" + s][0] > 0.05 and sign * at["Hand" + s][0] > 0.3  # left is +X
        if "Toes" + s in at:
            assert float((at["Toes" + s] - at["Foot" + s]) @ fwd) > 0.08  # toes point forward
        drop = float(at["UpperArm" + s][up] - at["Hand" + s][up])
        reach = float((at["Hand" + s] - at["UpperArm" + s]).norm())
        if c.rest == "T":
            assert abs(drop) < 0.01
        else:
            assert drop == pytest.approx(reach * 2**-0.5, abs=0.01)  # 45 degrees down


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_bvh_round_trip(c):
    sk = c.skeleton
    # names as they are: Biped's "Bip01 L Thigh" has spaces, UE has a joint called "root"
    text = format_bvh(rest_motion(sk, frames=4), c.layout)
    back, layout = parse_bvh(text, units=c.layout.scale)
    bsk = back.skeleton
    # a file lists joints depth-first; SMPL keeps its own order, so compare joint by joint
    order = [bsk.index(n) for n in sk.names]
    assert sorted(order) == list(range(sk.num_joints))
    assert [bsk.parents[j] for j in order] == [-1 if p < 0 else order[p] for p in sk.parents]
    assert torch.allclose(bsk.offsets[order], sk.offsets, atol=1e-5)
    assert torch.allclose(back.lpos[:, order], rest_motion(sk, frames=4).lpos, atol=1e-5)
    assert [layout.channels[j] for j in order] == list(c.layout.channels)
    for j, e in sk.end_sites.items():
        assert torch.allclose(bsk.end_sites[order[j]], e, atol=1e-5)
    if c.name not in ("smpl", "smplx"):
        assert order == list(range(sk.num_joints))  # built in file order already


def test_keyword_like_joint_names_survive_parse_bvh():
    sk = case("ue4").skeleton
    back, _ = parse_bvh(format_bvh(rest_motion(sk), case("ue4").layout), units=0.01)
    assert back.skeleton.names[0] == "root"


@pytest.mark.parametrize("name", sorted(NON_HUMANOID))
def test_non_humanoid_skeletons_are_valid(name):
    sk = NON_HUMANOID[name]
    assert sk.num_joints >= 5 and torch.isfinite(sk.offsets).all()
    assert not {"LeftArm", "LeftHand", "LeftShoulder", "LeftUpperArm"} & set(sk.names)


def test_two_roots_bvh_holds_two_figures():
    head, motion = TWO_ROOTS_BVH.split("MOTION\n")
    assert len(re.findall(r"^ROOT ", head, re.MULTILINE)) == 2
    n_channels = sum(int(m) for m in re.findall(r"CHANNELS (\d+)", head))
    lines = motion.splitlines()
    assert lines[0] == "Frames: 2" and len(lines) == 4
    assert all(len(row.split()) == n_channels for row in lines[2:])
