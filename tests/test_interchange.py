"""FBX and glTF in and out (video2style.interchange): clips built with Blender from the rig corpus."""
from pathlib import Path

import pytest
import torch

from testkit.clips import corpus_bvh, positions, run_script, twist_deg, zero_style
from tests.helpers import needs_blender
from video2style import interchange
from video2style.interchange import Converter

# Blender-side helper for these tests: build a skinned mesh onto a file's armature, or report what a file holds.


def worst_turn(a: Path, b: Path) -> float:
    """Largest angle (degrees) between the global rotations of same-named joints of two BVH files: twist included."""
    from motioncore import quat
    from motioncore.bvh import read_bvh
    from motioncore.kinematics import fk

    ma, _ = read_bvh(a)
    mb, _ = read_bvh(b)
    ga = fk(ma.lrot, ma.lpos, ma.skeleton.parents)[0]
    gb = fk(mb.lrot, mb.lpos, mb.skeleton.parents)[0][:, [mb.skeleton.names.index(n) for n in ma.skeleton.names]]
    w = quat.mul(quat.inv(ga), gb)[..., 0].abs().clamp(max=1.0)
    return float(torch.rad2deg(2 * torch.acos(w)).max())


def rest_gaps(a: dict, b: dict) -> tuple[float, float]:
    """Two ``inspect`` reports' largest rest-pose differences: of the bones' rotation (3x3 entries), and of their
    heads relative to the rig's size (translations are in the file's units, centimetres for Mixamo: float32 noise
    there grows with the size, up to 2e-4 cm at 170 cm on the bpy 4.2 route)."""
    assert a["bones"].keys() == b["bones"].keys()
    size = max(1.0, max(abs(m[i][3]) for m in a["bones"].values() for i in range(3)))
    turn = max(abs(ma[i][j] - mb[i][j]) for n, ma in a["bones"].items() for mb in [b["bones"][n]]
               for i in range(3) for j in range(3))
    move = max(abs(ma[i][3] - mb[i][3]) for n, ma in a["bones"].items() for mb in [b["bones"][n]] for i in range(3))
    return turn, move / size


def worst_gap(a: Path, b: Path) -> float:
    """Largest distance (m) between same-named joints of two BVH files, frame for frame."""
    na, pa, fa = positions(a)
    nb, pb, fb = positions(b)
    assert sorted(na) == sorted(nb) and pa.shape == pb.shape and fa == fb
    return float((pa - pb[:, [nb.index(n) for n in na]]).norm(dim=-1).max())


@pytest.fixture(scope="module")
def converter():
    with Converter() as conv:
        yield conv


@pytest.mark.slow
@needs_blender
@pytest.mark.parametrize("fmt", ["fbx", "glb"])
@pytest.mark.parametrize("rig", ["mixamo", "ue5", "rigify"])
def test_bvh_to_file_to_bvh_within_a_millimetre(tmp_path, converter, rig, fmt):
    bvh = corpus_bvh(tmp_path, rig)
    clip = converter.write(bvh, tmp_path / f"walk.{fmt}")
    back = converter.to_bvh(clip)
    assert worst_gap(bvh, back) < 1e-3
    info = converter.info(clip)
    assert info["fps"] == pytest.approx(30.0) and info["frame_end"] - info["frame_start"] + 1 == 60
    # the result keyed back onto the file's own armature reads back the same again
    again = converter.write(back, tmp_path / "out" / f"walk.{fmt}", source=clip)
    assert worst_gap(bvh, converter.to_bvh(again)) < 1e-3
    assert converter.info(again)["frame_start"] == info["frame_start"]
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]  # no temporary file left
    if rig == "mixamo":  # without a skin to carry a bind pose, the rest pose is the bones' node transforms: kept too
        a, b = run_script("inspect", clip), run_script("inspect", again)
        assert a["bones"].keys() == b["bones"].keys() and a["range"] == b["range"] and a["fps"] == b["fps"]
        turn, move = rest_gaps(a, b)
        assert turn < 1e-4 and move < 1e-5, (turn, move)


@pytest.mark.slow
@needs_blender
@pytest.mark.parametrize("rig,fmt", [("mixamo", "fbx"), ("ue5", "glb")])
def test_apply_writes_onto_the_files_own_armature_and_mesh(tmp_path, rig, fmt):
    from testkit.rig_corpus import case
    from video2style.cli import main

    bvh = corpus_bvh(tmp_path / "src", rig)
    with Converter() as conv:
        bare = conv.write(bvh, tmp_path / "src" / f"bare.{fmt}")
    clip = tmp_path / "in" / f"walk.{fmt}"
    clip.parent.mkdir()
    run_script("skin", bare, out=str(clip), format=fmt)
    out = tmp_path / "out"
    assert main(["apply", str(zero_style(tmp_path)), str(tmp_path / "in"), "-o", str(out), "--no-preview"]) == 0
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".video2style")) == ["report.json", f"walk.{fmt}"]
    a, b = run_script("inspect", clip), run_script("inspect", out / f"walk.{fmt}")
    assert a["meshes"] and a["meshes"] == b["meshes"]  # mesh, skin weights, materials, parent armature
    assert a["bones"].keys() == b["bones"].keys()
    turn, move = rest_gaps(a, b)
    assert turn < 1e-4 and move < 1e-5, (turn, move)  # rest pose and roll as they were
    assert a["fps"] == b["fps"] and a["range"] == b["range"]
    heads = torch.tensor([[pa[n][0] for n in pa] for pa in a["poses"]])
    heads_b = torch.tensor([[pb[n][0] for n in pa] for pa, pb in zip(a["poses"], b["poses"])])
    height = float(heads[..., 2].amax() - heads[..., 2].amin())
    assert float((heads - heads_b).norm(dim=-1).max()) < 0.03 * height / 1.7  # a zero style: the content, feet cleaned
    roles = {j for j in case(rig).expected.values() if j}
    twists = sorted(twist_deg(pa[n][1], pb[n][1]) for pa, pb in zip(a["poses"], b["poses"]) for n in roles)
    # the twist bounds of docs/results.md#any-humanoid-rig
    assert twists[int(0.99 * (len(twists) - 1))] <= 15.0 and twists[-1] < 150.0


@pytest.mark.slow
@needs_blender
def test_format_options_and_a_bvh_result_from_fbx(tmp_path, converter):
    from video2style.cli import main

    bvh = corpus_bvh(tmp_path / "in", "mixamo")
    fbx = converter.write(bvh, tmp_path / "fbx" / "walk.fbx")
    style = zero_style(tmp_path)
    assert main(["apply", str(style), str(fbx), "-o", str(tmp_path / "o1"), "--no-preview", "--format", "bvh"]) == 0
    assert worst_gap(bvh, tmp_path / "o1" / "walk.bvh") < 0.05
    assert main(["apply", str(style), str(bvh), "-o", str(tmp_path / "o2"), "--no-preview", "--format", "glb"]) == 0
    assert not (tmp_path / "o2" / "walk.bvh").exists()
    assert worst_gap(tmp_path / "o1" / "walk.bvh", converter.to_bvh(tmp_path / "o2" / "walk.glb")) < 0.05
    # FBX in, GLB out: keyed onto the FBX's armature, exported by the glTF exporter; the same result as BVH out
    assert main(["apply", str(style), str(fbx), "-o", str(tmp_path / "o3"), "--no-preview", "--format", "glb"]) == 0
    assert worst_gap(tmp_path / "o1" / "walk.bvh", converter.to_bvh(tmp_path / "o3" / "walk.glb")) < 1e-3


def test_without_blender_one_line_names_the_file_and_both_routes(tmp_path, monkeypatch, capsys):
    from video2style.cli import main

    clip = tmp_path / "in" / "walk.fbx"
    clip.parent.mkdir()
    clip.write_bytes(b"Kaydara FBX Binary  \x00")
    monkeypatch.setattr(interchange, "blender_command", lambda: None)
    monkeypatch.delenv("VIDEO2STYLE_BLENDER", raising=False)
    assert main(["apply", str(zero_style(tmp_path)), str(clip), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    line = next(ln for ln in err.splitlines() if "walk.fbx" in ln)
    assert "video2style[fbx]" in line and "apt install blender" in line
    assert not list((tmp_path / "out").glob("walk*"))


@pytest.mark.slow
def test_a_blender_that_never_answers_is_stopped_with_one_line(tmp_path, monkeypatch):
    import sys
    import time

    hung = [sys.executable, "-c", "import sys, time; sys.stdin.readline(); time.sleep(120)"]
    monkeypatch.setattr(interchange, "blender_command", lambda: hung)
    blender = interchange.Blender(timeout=1.0)
    t0 = time.time()
    with pytest.raises(interchange.InterchangeError, match=r"walk\.fbx: Blender gave no answer within 1 s"):
        blender.call({"op": "read"}, tmp_path / "walk.fbx")
    assert time.time() - t0 < 30
    assert blender._proc is None  # ended, not left running


@pytest.mark.slow
@needs_blender
def test_files_without_an_armature_or_animation_or_with_two_are_one_line(tmp_path, converter, capsys):
    from video2style.cli import main

    fbx = converter.write(corpus_bvh(tmp_path / "src", "mixamo"), tmp_path / "src" / "walk.fbx")
    odd = tmp_path / "odd"
    odd.mkdir()
    run_script("odd", fbx, out=str(odd))
    for name, said in (("mesh_only.glb", "no armature"), ("still.fbx", "has no animation"),
                       ("two.fbx", "--armature")):
        assert main(["skeleton", str(odd / name)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(odd / name) in err[0] and said in err[0], err
    assert main(["skeleton", str(odd / "two.fbx"), "--armature", "Armature.001"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{odd / 'two.fbx'}: ") and "mixamorig:LeftArm" in out
    # two takes: the active one is used and the choice said; --action picks another; a wrong name lists them
    assert main(["skeleton", str(odd / "takes.fbx")]) == 0
    err = capsys.readouterr().err
    assert "used action" in err and "Second" in err and "--action" in err
    assert main(["skeleton", str(odd / "takes.fbx"), "--action", "nothing"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no action 'nothing'" in err[0] and "Second" in err[0]


@pytest.mark.slow
@needs_blender
def test_preview_and_learn_take_fbx_and_glb(tmp_path, converter):
    from video2style.cli import main

    bvh = corpus_bvh(tmp_path / "src", "ue5", seconds=3.0)
    glb = converter.write(bvh, tmp_path / "src" / "walk.glb")
    fbx = converter.write(bvh, tmp_path / "src" / "walk.fbx")
    assert main(["preview", str(glb), str(fbx), "-o", str(tmp_path / "ab.mp4")]) == 0
    assert (tmp_path / "ab.mp4").stat().st_size > 1000
    assert main(["learn", str(fbx), "-o", str(tmp_path / "s.v2s"), "--iterations", "2", "--allow-partial",
                 "--text", "a person walks"]) == 0
    assert (tmp_path / "s.v2s").is_file()


@pytest.mark.slow
@needs_blender
def test_batch_styles_fbx_content_into_fbx_and_resumes(tmp_path, converter, monkeypatch):
    import shutil

    from video2style import batch

    style = zero_style(tmp_path, 0.05)  # random adapters: a style that moves joints by up to ~15 cm
    monkeypatch.setattr("video2style.pipeline.learn_file",
                        lambda video, out, **kw: (out.parent.mkdir(parents=True, exist_ok=True), shutil.copy(style, out)))
    videos, content = tmp_path / "videos", tmp_path / "content"
    videos.mkdir()
    (videos / "v.mp4").write_bytes(b"not read by the fake learner")
    converter.write(corpus_bvh(tmp_path / "src", "mixamo"), content / "sub" / "walk.fbx")
    shutil.copy(tmp_path / "src" / "walk.bvh", content / "plain.bvh")
    report = batch.run_batch(videos, content, tmp_path / "out", progress=lambda s: None)
    assert [r["status"] for r in report.rows] == ["done", "done"], report.rows
    assert (tmp_path / "out" / "v" / "sub" / "walk.fbx").is_file() and (tmp_path / "out" / "v" / "plain.bvh").is_file()
    assert not (tmp_path / "out" / "v" / "sub" / "walk.bvh").exists()
    styled_fbx = converter.to_bvh(tmp_path / "out" / "v" / "sub" / "walk.fbx")
    assert worst_gap(tmp_path / "out" / "v" / "plain.bvh", styled_fbx) < 1e-3  # the FBX route styles as the BVH one
    assert worst_turn(tmp_path / "out" / "v" / "plain.bvh", styled_fbx) < 0.5  # every bone's twist too (6-decimal text)
    again = batch.run_batch(videos, content, tmp_path / "out", progress=lambda s: None)
    assert [r["status"] for r in again.rows] == ["skipped (done)"] * 2


@pytest.mark.slow
@needs_blender
def test_a_failed_write_back_leaves_none_of_the_clips_outputs(tmp_path, converter, monkeypatch, capsys):
    from video2style.cli import main

    fbx = converter.write(corpus_bvh(tmp_path / "src", "mixamo"), tmp_path / "in" / "walk.fbx")

    def broken(self, bvh, out, source=None):
        raise interchange.InterchangeError(f"{source}: Blender: the disk is full")

    monkeypatch.setattr(Converter, "write", broken)
    assert main(["apply", str(zero_style(tmp_path)), str(fbx), "-o", str(tmp_path / "out")]) == 1
    assert "the disk is full" in capsys.readouterr().err
    assert not [p.name for p in (tmp_path / "out").iterdir() if not p.name.startswith(".video2style")]


def test_folders_of_clips_leave_results_out(tmp_path):
    from video2style.interchange import find_clip_files

    for rel in ("a/walk.FBX", "b/run.glb", "c/x.gltf", "old_results/walk.fbx", "out/walk.fbx", "notes.txt"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(b"x")
    (tmp_path / "old_results" / ".video2style.lock").write_text("pid 1")
    assert [p.relative_to(tmp_path).as_posix() for p in find_clip_files(tmp_path, tmp_path / "out")] == \
        ["a/walk.FBX", "b/run.glb", "c/x.gltf"]


@pytest.mark.slow
@needs_blender
def test_errors_after_reading_name_the_users_file(tmp_path, converter, capsys):
    from motioncore.bvh import BvhLayout, write_bvh
    from testkit.rig_corpus import NON_HUMANOID, rest_motion
    from video2style.cli import main

    dog = NON_HUMANOID["quadruped"]
    bvh = tmp_path / "dog.bvh"
    write_bvh(bvh, rest_motion(dog, frames=30), BvhLayout.default(dog))
    fbx = converter.write(bvh, tmp_path / "in" / "dog.fbx")
    assert main(["skeleton", str(fbx)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(fbx) in err[0] and "interchange" not in err[0], err
    assert main(["apply", str(zero_style(tmp_path)), str(fbx), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert str(fbx) in err and "video2style-interchange" not in err, err


def test_video2style_blender_chooses_the_blender_even_where_bpy_is_there(tmp_path, monkeypatch):
    """$VIDEO2STYLE_BLENDER names the Blender to run; without it the bpy module comes first, then `blender` on PATH
    (it used to be read only where bpy was absent: a child with the fake Blender of a test ran the real bpy)."""
    import importlib.util
    import sys

    exe = tmp_path / "bin" / "my-blender"
    exe.parent.mkdir()
    exe.write_text("#!/bin/sh\nexit 0\n")
    exe.chmod(0o755)
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: object() if name == "bpy" else real(name, *a))
    monkeypatch.delenv("VIDEO2STYLE_BLENDER", raising=False)
    assert interchange.blender_command() == [sys.executable, str(interchange.SCRIPT)]
    monkeypatch.setenv("VIDEO2STYLE_BLENDER", str(exe))
    assert interchange.blender_command()[:2] == [str(exe), "-b"]
    monkeypatch.setenv("VIDEO2STYLE_BLENDER", str(tmp_path / "bin" / "missing"))
    assert interchange.blender_command() is None
    with pytest.raises(interchange.InterchangeError, match=r"walk\.fbx: \$VIDEO2STYLE_BLENDER names .*missing.*not an "
                                                           r"executable"):
        interchange.Blender().call({"op": "read"}, tmp_path / "walk.fbx")


@pytest.mark.slow
@needs_blender
def test_a_gltf_result_is_one_file_that_reads_back(tmp_path, converter):
    """Issue 53, item 6: the bpy 4.2 route's glTF exporter offers the one-file .gltf format only once its add-on
    allows it ("enum GLTF_EMBEDDED not found in ('GLB', 'GLTF_SEPARATE')"); Blender 3.4's always does."""
    import json

    from video2style.cli import main

    bvh = corpus_bvh(tmp_path / "in", "mixamo")
    fbx = converter.write(bvh, tmp_path / "fbx" / "walk.fbx")
    made = converter.write(bvh, tmp_path / "new" / "walk.gltf")  # a new armature
    assert main(["apply", str(zero_style(tmp_path)), str(fbx), "-o", str(tmp_path / "out"), "--no-preview",
                 "--format", "gltf"]) == 0  # keyed onto the FBX's armature
    for gltf in (made, tmp_path / "out" / "walk.gltf"):
        assert sorted(p.name for p in gltf.parent.iterdir() if not p.name.startswith(".")) in (
            ["walk.gltf"], ["report.json", "walk.gltf"])  # one file: no .bin or images beside it
        doc = json.loads(gltf.read_text())
        assert doc["buffers"] and all(b["uri"].startswith("data:") for b in doc["buffers"])
    assert worst_gap(bvh, converter.to_bvh(made)) < 1e-3
    assert worst_gap(tmp_path / "in" / "walk.bvh", converter.to_bvh(tmp_path / "out" / "walk.gltf")) < 0.05
