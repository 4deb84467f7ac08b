"""FBX and glTF in and out (video2style.interchange): clips built with Blender from the rig corpus."""
import copy
import functools
import json
import math
import subprocess
from pathlib import Path

import pytest
import torch

from video2style import interchange
from video2style.interchange import Converter, blender_command

# Blender-side helper for these tests: build a skinned mesh onto a file's armature, or report what a file holds.
SCRIPT = r'''
import importlib.util, json, sys
import bpy
args = json.loads(sys.argv[sys.argv.index("--") + 1])
spec = importlib.util.spec_from_file_location("blender_io", args["blender_io"])
io = importlib.util.module_from_spec(spec); spec.loader.exec_module(io)
if args["op"] == "odd":  # files video2style must refuse, or choose in
    out = args["out"]
    io._clear()
    bpy.ops.mesh.primitive_cube_add()
    io._export(out + "/mesh_only.glb", "glb")
    io._clear()
    io._import(args["path"])
    arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    arm.animation_data.action = None
    for a in list(bpy.data.actions):
        bpy.data.actions.remove(a)
    bpy.ops.export_scene.fbx(filepath=out + "/still.fbx", add_leaf_bones=False, bake_anim=False)
    io._clear()
    io._import(args["path"])
    arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    second = arm.animation_data.action.copy()
    second.name = "Second"
    for fc in second.fcurves:  # a different take: every key a frame later
        for kp in fc.keyframe_points:
            kp.co.x += 1
    track = arm.animation_data.nla_tracks.new()
    track.strips.new("Second", 1, second)
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 0, 60
    bpy.ops.export_scene.fbx(filepath=out + "/takes.fbx", add_leaf_bones=False, bake_anim_use_nla_strips=False,
                             bake_anim_use_all_actions=True)
    io._clear()
    io._import(args["path"])
    io._import(args["path"])
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 60
    bpy.ops.export_scene.fbx(filepath=out + "/two.fbx", add_leaf_bones=False, bake_anim_use_nla_strips=False,
                             bake_anim_use_all_actions=False)
    print("RESULT" + json.dumps({"ok": True}))
    sys.exit(0)
arm, act, *_ = io._load(args["path"], None, None)
if args["op"] == "skin":  # a box per bone, weighted to the bone and (top half) shared with its parent
    verts, faces, owners = [], [], []
    for b in arm.data.bones:
        c = (b.head_local + b.tail_local) / 2
        r = max(b.length * 0.15, 1e-3)
        base = len(verts)
        for i in range(8):
            verts.append((c.x + (r if i & 1 else -r), c.y + (r if i & 2 else -r), c.z + (r if i & 4 else -r)))
            owners.append((b.name, b.parent.name if (b.parent and i & 4) else None))
        faces += [(base + a, base + b_, base + c_, base + d) for a, b_, c_, d in
                  ((0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3))]
    me = bpy.data.meshes.new("Body")
    me.from_pydata(verts, [], faces)
    mat = bpy.data.materials.new("Skin")
    mat.diffuse_color = (0.8, 0.5, 0.4, 1.0)
    me.materials.append(mat)
    ob = bpy.data.objects.new("Body", me)
    bpy.context.scene.collection.objects.link(ob)
    ob.parent = arm
    ob.matrix_parent_inverse = arm.matrix_world.inverted()
    ob.modifiers.new("Armature", "ARMATURE").object = arm
    for v, (own, parent) in enumerate(owners):
        g = ob.vertex_groups.get(own) or ob.vertex_groups.new(name=own)
        g.add([v], 0.5 if parent else 1.0, "REPLACE")
        if parent:
            (ob.vertex_groups.get(parent) or ob.vertex_groups.new(name=parent)).add([v], 0.5, "REPLACE")
    s = bpy.context.scene
    s.frame_start, s.frame_end = io._frame_range(act)
    io._export(args["out"], args["format"])
    print("RESULT" + json.dumps({"ok": True}))
else:  # what the file holds
    meshes = {}
    for ob in bpy.data.objects:
        if ob.type != "MESH":
            continue
        # glTF splits vertices per face corner on import: count distinct points, each point's weights once
        seen = {(tuple(round(c, 5) for c in v.co), ob.vertex_groups[g.group].name, round(g.weight, 4))
                for v in ob.data.vertices for g in v.groups}
        w = {}
        for _, name, weight in seen:
            w[name] = round(w.get(name, 0.0) + weight, 3)
        points = {tuple(round(c, 5) for c in v.co) for v in ob.data.vertices}
        meshes[ob.name] = {"faces": len(ob.data.polygons), "verts": len(points), "weights": w,
                           "materials": [m.name for m in ob.data.materials if m], "armature": ob.find_armature().name
                           if ob.find_armature() else None}
    s = bpy.context.scene
    start, end = io._frame_range(act)
    frames = list(range(start, end + 1, max(1, (end - start) // 12)))
    poses = []
    for f in frames:
        s.frame_set(f)
        poses.append({pb.name: [list(arm.matrix_world @ pb.head), list((arm.matrix_world @ pb.matrix).to_quaternion())]
                      for pb in arm.pose.bones})
    print("RESULT" + json.dumps({"bones": {b.name: [list(r) for r in b.matrix_local] for b in arm.data.bones},
                                 "meshes": meshes, "fps": s.render.fps / s.render.fps_base, "range": [start, end],
                                 "frames": frames, "poses": poses}))
'''


@functools.lru_cache(maxsize=1)
def _blender_problem() -> str | None:
    cmd = blender_command()
    if cmd is None:
        return "neither the bpy module nor a `blender` on PATH (pip install \"video2style[fbx]\" or apt install blender python3-numpy)"
    if "--python" in cmd:  # blender -b: its own Python must have numpy
        probe, env = [cmd[0], "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", "import numpy"], \
            interchange.blender_env()
    else:
        probe, env = [cmd[0], "-c", "import bpy, numpy"], None
    proc = subprocess.run(probe, check=False, capture_output=True, text=True, timeout=120, env=env)
    if proc.returncode != 0:
        return "Blender's Python lacks numpy, which its FBX/glTF add-ons need (apt install python3-numpy)"
    return None


needs_blender = pytest.mark.skipif(_blender_problem() is not None, reason=f"no usable Blender: {_blender_problem()}")


def run_script(op: str, path: Path, **extra) -> dict:
    cmd = blender_command()
    cmd = [*cmd[:-1], str(path.parent / "helper.py")]
    (path.parent / "helper.py").write_text(SCRIPT)
    args = json.dumps({"op": op, "path": str(path), "blender_io": str(interchange.SCRIPT), **extra})
    env = None if "--python" not in cmd else interchange.blender_env()
    proc = subprocess.run([*cmd, "--", args], check=False, capture_output=True, text=True, timeout=300, env=env)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT")), None)
    assert line is not None, proc.stdout[-2000:] + proc.stderr[-2000:]
    return json.loads(line[len("RESULT"):])


def corpus_bvh(folder: Path, rig: str, seconds: float = 2.0) -> Path:
    from motioncore.bvh import write_bvh
    from motioncore.retarget import from_canonical, make_rig
    from tests.helpers import random_motion
    from tests.rig_corpus import case

    c = case(rig)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "walk.bvh"
    write_bvh(path, from_canonical(random_motion(seconds=seconds, fps=30.0, seed=4, amplitude=0.3), make_rig(c.skeleton)),
              c.layout)
    return path


def positions(bvh: Path) -> tuple[list[str], torch.Tensor, float]:
    """Joint names, global positions (T, J, 3) in metres, fps."""
    from motioncore.bvh import read_bvh

    m, _ = read_bvh(bvh)
    return list(m.skeleton.names), m.global_positions(), m.fps


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
        assert max(abs(x - y) for n in a["bones"] for ra, rb in zip(a["bones"][n], b["bones"][n])
                   for x, y in zip(ra, rb)) < 1e-4


def twist_deg(qa: list[float], qb: list[float]) -> float:
    """Swing-twist split of the rotation from ``qa`` to ``qb`` (world wxyz) in ``qa``'s frame; the twist about Y."""
    from motioncore import quat

    d = quat.mul(quat.inv(torch.tensor(qa, dtype=torch.float64)), torch.tensor(qb, dtype=torch.float64))
    w, y = float(d[0]), float(d[2])
    return math.degrees(2 * math.acos(min(1.0, abs(w) / max(math.hypot(w, y), 1e-12))))


def zero_style(tmp_path: Path, scale: float = 0.0) -> Path:
    """A style file of zero adapters (the result is the content, feet cleaned), or of random ones ``scale`` large
    (a style that changes the motion)."""
    from transfer.bundle import load_models
    from transfer.lora import add_lora, lora_state
    from transfer.style_file import Style

    model = copy.deepcopy(load_models().prior)
    add_lora(model, rank=8)
    gen = torch.Generator().manual_seed(0)
    tensors = {k: torch.randn(v.shape, generator=gen) * scale for k, v in lora_state(model).items()}
    style = tmp_path / f"style{scale:g}.v2s"
    Style(tensors, {"style": "zero" if scale == 0 else "random", "rank": 8}).save(style)
    return style


@needs_blender
@pytest.mark.parametrize("rig,fmt", [("mixamo", "fbx"), ("ue5", "glb")])
def test_apply_writes_onto_the_files_own_armature_and_mesh(tmp_path, rig, fmt):
    from tests.rig_corpus import case
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
    rest = max(abs(x - y) for n in a["bones"] for ra, rb in zip(a["bones"][n], b["bones"][n]) for x, y in zip(ra, rb))
    assert rest < 1e-4  # rest pose and roll as they were
    assert a["fps"] == b["fps"] and a["range"] == b["range"]
    heads = torch.tensor([[pa[n][0] for n in pa] for pa in a["poses"]])
    heads_b = torch.tensor([[pb[n][0] for n in pa] for pa, pb in zip(a["poses"], b["poses"])])
    height = float(heads[..., 2].amax() - heads[..., 2].amin())
    assert float((heads - heads_b).norm(dim=-1).max()) < 0.03 * height / 1.7  # a zero style: the content, feet cleaned
    roles = {j for j in case(rig).expected.values() if j}
    twists = sorted(twist_deg(pa[n][1], pb[n][1]) for pa, pb in zip(a["poses"], b["poses"]) for n in roles)
    # the twist bounds of docs/results.md#any-humanoid-rig
    assert twists[int(0.99 * (len(twists) - 1))] <= 15.0 and twists[-1] < 150.0


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
    assert main(["apply", str(zero_style(tmp_path)), str(clip), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    line = next(ln for ln in err.splitlines() if "walk.fbx" in ln)
    assert "video2style[fbx]" in line and "apt install blender" in line
    assert not list((tmp_path / "out").glob("walk*"))


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


@needs_blender
def test_errors_after_reading_name_the_users_file(tmp_path, converter, capsys):
    from motioncore.bvh import BvhLayout, write_bvh
    from tests.rig_corpus import NON_HUMANOID, rest_motion
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
