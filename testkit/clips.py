"""Clips for the FBX/glTF tests and benchmarks: BVH files of the rig corpus, style files, and a Blender-side helper
that builds a skinned mesh onto a file's armature or reports what a file holds."""
from __future__ import annotations

import copy
import json
import math
import subprocess
from pathlib import Path

import torch

from video2style import interchange
from video2style.interchange import blender_command

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
    from testkit.motions import random_motion
    from testkit.rig_corpus import case

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
