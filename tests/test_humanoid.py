"""Automatic humanoid mapping on rigs in many tools' conventions (testkit/rig_corpus.py) and on the real files."""
from pathlib import Path

import pytest
import torch

from motioncore import quat
from motioncore.bvh import format_bvh, parse_bvh, read_bvh, write_bvh
from motioncore.humanoid import NotHumanoidError, find_humanoid, name_side
from motioncore.motion import Motion
from motioncore.retarget import RetargetError, from_canonical, make_rig, to_canonical
from testkit.motions import random_motion
from testkit.rig_corpus import CASES, DISPUTED_CASES, NON_HUMANOID, TWO_ROOTS_BVH, case

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
ALL = CASES + DISPUTED_CASES


def test_the_corpus_covers_the_conventions_the_readme_lists():
    names = {c.name for c in CASES}
    assert len(names) >= 12 and {"mixamo", "ue4", "ue5", "unity", "cmu_hips", "cmu_lhipjoint", "rokoko", "biped",
                                 "rigify", "smpl", "smplx", "vrm", "hik", "bandai", "animated_drawings"} <= names
    assert {c.up for c in CASES} == {"Y", "Z"} and {c.rest for c in CASES} == {"T", "A"}
    assert {c.units for c in CASES} == {"m", "cm", "in"}


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_every_role_is_found_from_the_rest_pose(c):
    found = find_humanoid(c.skeleton)
    assert found.names(c.skeleton) == c.expected
    assert found.up == {"Y": "+Y", "Z": "+Z"}[c.up] and found.forward == {"Y": "+Z", "Z": "-Y"}[c.up]


@pytest.mark.parametrize("c", ALL, ids=lambda c: c.name)
def test_names_do_not_matter_where_the_feet_show_the_facing(c):
    sk = c.skeleton
    anon = type(sk)(tuple(f"j{i}" for i in range(sk.num_joints)), sk.parents, sk.offsets, sk.end_sites)
    found = find_humanoid(anon)
    expected = {r: None if n is None else f"j{sk.index(n)}" for r, n in c.expected.items()}
    if c.expected["Toes_L"] is None and not sk.end_sites:
        pytest.skip("no toes and no foot End Site: only names tell left from right")
    heads = {r for r, n in found.names(anon).items() if n != expected[r]}
    assert heads <= {"Head"}  # without its name, the head of a neck chain is found by height alone
    if heads:
        assert c.name in ("ue4", "ue5", "vrm", "vroid", "smplx")  # head with eyes/jaw or no head-top End Site


def _bvh_round_trip(c, seconds: float = 2.0):
    """Canonical -> the case's rig -> BVH text (its units, channels, Euler orders) -> parsed -> canonical."""
    rig = make_rig(c.skeleton)
    m = random_motion(seconds=seconds, seed=7, amplitude=0.4)
    m.lrot[:, [r for r, s in enumerate(rig.mapping) if s is None]] = quat.identity()  # roles it has no bone for
    text = format_bvh(from_canonical(m, rig), c.layout)
    parsed, layout = parse_bvh(text, f"{c.name}.bvh", units=c.layout.scale)
    back_rig = make_rig(parsed.skeleton, parsed, source=f"{c.name}.bvh")
    return m, parsed, layout, back_rig


@pytest.mark.parametrize("c", CASES, ids=lambda c: c.name)
def test_canonical_to_rig_file_and_back_within_1mm(c):
    m, parsed, _, rig = _bvh_round_trip(c)
    assert rig.map_name == "auto" and rig.humanoid.names(parsed.skeleton) == c.expected
    back = to_canonical(parsed, rig)
    err = (back.global_positions() - m.global_positions()).norm(dim=-1).max()
    assert float(err) < 1e-3


def _fingers_moving(motion: Motion, rig) -> Motion:
    lrot = motion.lrot.clone()
    for j in range(1, motion.skeleton.num_joints):
        if j not in rig.mapping:
            angle = 0.4 * torch.sin(torch.arange(motion.num_frames) / 5.0 + j)
            lrot[:, j] = quat.mul(lrot[:, j], quat.from_axis_angle(torch.tensor([0.0, 0.0, 1.0]), angle))
    return Motion(motion.skeleton, lrot, motion.lpos, motion.fps)


@pytest.mark.parametrize("name", ["mixamo", "ue5", "rokoko", "biped", "rigify", "smplx", "hik", "bandai"])
def test_written_result_keeps_joints_channels_frame_time_and_fingers(name, tmp_path):
    """What apply writes: the file's joints, channel layout, frame time and frame count, the extras' curves."""
    from video2style.pipeline import read_clip, write_result

    c = case(name)
    rig = make_rig(c.skeleton)
    motion = _fingers_moving(from_canonical(random_motion(seconds=2.0, fps=30.0, seed=3, amplitude=0.3), rig), rig)
    src = tmp_path / f"{name}.bvh"
    write_bvh(src, motion, c.layout)
    clip = read_clip(src)
    styled = random_motion(seconds=clip.canonical.duration, seed=9, amplitude=0.15)
    result = Motion(clip.canonical.skeleton, quat.mul(clip.canonical.lrot, styled.lrot[: clip.canonical.num_frames]),
                    clip.canonical.lpos, clip.canonical.fps)
    out = tmp_path / "out" / f"{name}.bvh"
    write_result(clip, result, out)
    src_text, out_text = src.read_text(), out.read_text()
    assert src_text.split("MOTION")[1].splitlines()[1:3] == out_text.split("MOTION")[1].splitlines()[1:3]  # frames, time
    a, la = parse_bvh(src_text, units=c.layout.scale)
    b, lb = parse_bvh(out_text, units=c.layout.scale)
    assert a.skeleton.names == b.skeleton.names and a.skeleton.parents == b.skeleton.parents and la == lb  # channels
    assert torch.allclose(a.skeleton.offsets, b.skeleton.offsets, atol=1e-6)  # file units, as written
    extras = [j for j in range(a.skeleton.num_joints) if j not in clip.rig.mapping]
    assert extras, "the rig has joints without a role"
    assert (quat.angle(quat.mul(quat.inv(a.lrot[:, extras]), b.lrot[:, extras])) < 1e-4).all()  # fingers unchanged
    moved = quat.angle(quat.mul(quat.inv(a.lrot), b.lrot)).amax(0)
    assert float(moved[[j for j in clip.rig.mapping if j is not None]].max()) > 0.05  # the style did land


@pytest.mark.parametrize("name", sorted(NON_HUMANOID))
def test_non_humanoid_is_one_line_naming_what_is_missing(name):
    sk = NON_HUMANOID[name]
    with pytest.raises(NotHumanoidError):
        find_humanoid(sk)
    with pytest.raises(RetargetError) as e:
        make_rig(sk, source=f"{name}.bvh")
    msg = str(e.value)
    assert msg.startswith(f"{name}.bvh: not a humanoid") and "not found" in msg and "\n" not in msg
    assert f"video2style skeleton {name}.bvh --write-map map.json" in msg


def test_two_figures_in_one_file_is_one_line():
    with pytest.raises(ValueError, match=r"two\.bvh:\d+: a second ROOT"):
        parse_bvh(TWO_ROOTS_BVH, "two.bvh")


@pytest.mark.parametrize("name,side", [("LeftUpLeg", 1), ("thigh_r", -1), ("Bip01 L Thigh", 1), ("DEF-thigh.R", -1),
                                       ("LHipJoint", 1), ("mixamorig:RightHand", -1), ("Hips", 0), ("leftEye", 1)])
def test_name_sides(name, side):
    assert name_side(name) == side


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/data not present (real foreign skeletons)")
def test_real_xia_and_fair1_files_map_like_their_names_say():
    files = sorted((SHARED / "xia_test").glob("*.bvh")) + sorted((SHARED / "bvh_misc").glob("*.bvh"))
    assert files
    for f in files:
        m, _ = read_bvh(f)
        rig = make_rig(m.skeleton, m, source=str(f))
        got = rig.humanoid.names(m.skeleton)
        for side, s in (("Left", "L"), ("Right", "R")):
            assert got[f"UpperArm_{s}"] == f"{side}Arm" and got[f"Hand_{s}"] == f"{side}Hand", f
            assert got[f"UpperLeg_{s}"] == f"{side}UpLeg" and got[f"Toes_{s}"] == f"{side}ToeBase", f
        assert got["Head"] == "Head" and got["Hips"] == "Hips", f


def test_skeleton_command_reports_writes_an_editable_map_and_draws_the_roles(tmp_path, capsys):
    import json

    import cv2

    from video2style.cli import main

    c = case("ue5")
    clip = tmp_path / "manny.bvh"
    write_bvh(clip, from_canonical(random_motion(seconds=1.0, seed=1, amplitude=0.2), make_rig(c.skeleton)), c.layout)
    mp, png = tmp_path / "map.json", tmp_path / "roles.png"
    assert main(["skeleton", str(clip), "--write-map", str(mp), "--preview", str(png)]) == 0
    out = capsys.readouterr().out
    assert "UpperArm_L   upperarm_l" in out and "centimetres" in out and "up axis: +Z" in out
    assert "under Hand_L:" in out and "above Hips: root" in out
    assert json.loads(mp.read_text()) == c.expected
    img = cv2.imread(str(png))
    assert img is not None and img.shape[0] >= 480 and img.std() > 10
    # an edited, partial map overrides only what it names, and the report says so
    mp.write_text(json.dumps({"Neck": "neck_02"}))
    assert main(["skeleton", str(clip), "--joint-map", str(mp)]) == 0
    out = capsys.readouterr().out
    assert "Neck         neck_02" in out and "your joint map" in out and "mapping: auto+user" in out


def test_skeleton_command_on_a_quadruped_is_one_line_and_a_template_to_fill(tmp_path, capsys):
    import json

    from video2style.cli import main

    clip = tmp_path / "dog.bvh"
    sk = NON_HUMANOID["quadruped"]
    write_bvh(clip, Motion(sk, quat.identity(3, sk.num_joints), sk.offsets.expand(3, -1, -1).clone(), 30.0))
    mp = tmp_path / "map.json"
    assert main(["skeleton", str(clip)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a humanoid" in err and "--write-map" in err and not mp.exists()
    assert main(["skeleton", str(clip), "--write-map", str(mp)]) == 1
    assert "a template" in capsys.readouterr().err
    assert set(json.loads(mp.read_text()).values()) == {None}
    from video2style.pipeline import read_clip

    with pytest.raises(RetargetError, match="not a humanoid"):  # what apply and learn read clips with
        read_clip(clip)
