"""The Blender side of :mod:`video2style.interchange`: runs inside Blender (``blender -b --factory-startup
--python blender_io.py``) or a Python with the ``bpy`` module (``python blender_io.py``), never imported by
video2style itself.

One process serves a whole command: it reads one JSON job per line on stdin and answers each with one
line ``V2S-RESULT {json}`` on stdout (Blender prints its own chatter there too), until stdin closes.

Jobs (every path absolute; each job starts from an empty scene):

* ``{"op": "read", "path": F, "bvh": B, "armature": name|null, "action": name|null, "blend": P|null}``:
  import F (.fbx, .glb, .gltf), pick its armature and action, write that action as BVH to B in the
  armature's own space and units (Blender's BVH exporter), and the imported scene to the .blend P.
  Answers the armature, action, both lists, fps and frame range.
* ``{"op": "write", "source": F|null, "motion": NPZ, "out": O, "format": "fbx"|"glb"|"gltf", "armature",
  "action", "up": "+Y"|"+Z"|...}``: with a source, import F again and key its armature's bones (matched by name)
  to the global joint transforms in NPZ (``names``, ``grot`` (T, J, 4) wxyz and ``gpos`` (T, J, 3) in
  armature units and axes, ``fps``, ``frame_start``), replacing the chosen action; everything else in the
  file (meshes, materials, skin weights, rest pose, roll, other bones' names) is what the importer made.
  Without a source, NPZ also carries the skeleton (``parents``, ``offsets``) and a new armature is built.
  With ``blend`` (the read job's .blend), that scene is opened instead of importing F again. The armature's
  other actions (``actions``: the read's list, the file's first one first) are written beside the styled one as
  they were, each a take (FBX) or animation (glTF) of its own name. Then export O. Answers the frame range
  written.
"""
import contextlib
import itertools
import json
import math
import os
import sys
import traceback

import bpy
import numpy
from mathutils import Euler, Quaternion, Vector

if not hasattr(numpy, "bool"):  # Blender 3.4's glTF importer still says numpy.bool
    numpy.bool = bool


class JobError(Exception):
    """Said to the user in one line."""


def _clear():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _import(path):
    suffix = os.path.splitext(path)[1].lower()
    if suffix == ".fbx":
        # anim_offset 0: FBX time t is frame t * fps, as the exporter writes it (the default 1 moves a
        # clip one frame later at each round trip)
        bpy.ops.import_scene.fbx(filepath=path, use_anim=True, anim_offset=0.0, automatic_bone_orientation=False,
                                 ignore_leaf_bones=False)
    elif suffix in (".glb", ".gltf"):
        bpy.ops.import_scene.gltf(filepath=path)
    else:
        raise JobError(f"{path}: expected .fbx, .glb or .gltf")


def _bone_of(data_path):
    if data_path.startswith('pose.bones["'):
        return data_path[len('pose.bones["'):].split('"]', 1)[0]
    return None


def _assigned(obj):
    """The actions an object plays: its active one and those of its NLA strips."""
    data = obj.animation_data
    if data is None:
        return set()
    found = {data.action} if data.action is not None else set()
    for track in data.nla_tracks:
        found |= {strip.action for strip in track.strips if strip.action is not None}
    return found


def _actions_for(arm):
    """Actions that animate some bone of ``arm``, its active one first; an action another armature plays is
    that one's, not ``arm``'s (two rigs with the same bone names: a prop's armature must not take the walk)."""
    names = {b.name for b in arm.data.bones}
    own = _assigned(arm)
    others = set().union(*[_assigned(o) for o in bpy.data.objects if o.type == "ARMATURE" and o != arm])
    found = [a for a in bpy.data.actions if (a in own or a not in others)
             and any(_bone_of(fc.data_path) in names for fc in a.fcurves)]
    active = arm.animation_data.action if arm.animation_data else None
    return sorted(found, key=lambda a: (a != active, a.name))


def _choose(path, armature, action):
    """The armature and action to use; a note when there was a choice."""
    arms = sorted((o for o in bpy.data.objects if o.type == "ARMATURE"), key=lambda o: o.name)
    if not arms:
        raise JobError(f"{path}: no armature in the file (video2style styles skeletal animation)")
    names = [o.name for o in arms]
    if armature is not None:
        arm = next((o for o in arms if o.name == armature), None)
        if arm is None:
            raise JobError(f"{path}: no armature {armature!r}; the file has {', '.join(names)}")
    else:
        animated = [o for o in arms if _actions_for(o)]
        if len(animated) > 1:
            raise JobError(f"{path}: {len(animated)} animated armatures ({', '.join(o.name for o in animated)}); "
                           "choose one with --armature NAME")
        arm = animated[0] if animated else arms[0]
    actions = _actions_for(arm)
    if not actions:
        raise JobError(f"{path}: armature {arm.name!r} has no animation")
    if action is not None:  # the action's own name, or its take's as the file names it (FBX "Walk" for "Armature|Walk")
        act = (next((a for a in actions if a.name == action), None) or
               next((a for a in actions if _take_name(arm, a) == action), None))
        if act is None:
            raise JobError(f"{path}: no action {action!r} on {arm.name!r}; it has {', '.join(a.name for a in actions)}")
    else:
        act = actions[0]
    arm.animation_data_create()
    arm.animation_data.action = act
    notes = []
    if len(arms) > 1 and armature is None:  # the user chose none: say which was taken
        notes.append(f"used armature {arm.name!r} of {', '.join(names)} (--armature to choose)")
    if len(actions) > 1 and action is None:
        notes.append(f"used action {act.name!r} of {', '.join(a.name for a in actions)} (--action to choose)")
    return arm, act, names, [a.name for a in actions], notes


def _take_name(arm, act):
    """The name the file gives action ``act`` of ``arm``: its NLA track's (the glTF importer puts each animation in a
    track of its name), else its own without the ``<armature>|`` the FBX importer puts before a take's name."""
    data = arm.animation_data
    for track in data.nla_tracks if data is not None else ():
        if any(s.action == act for s in track.strips) and not track.name.startswith(("NlaTrack", "[Action Stash]")):
            return track.name
    prefix = f"{arm.name}|"
    return act.name[len(prefix):] if act.name.startswith(prefix) and len(act.name) > len(prefix) else act.name


def _frame_range(act):
    start, end = act.frame_range
    return math.floor(start + 1e-6), math.ceil(end - 1e-6)


def _gltf_fps(arm, act):
    """glTF stores seconds; the importer keys them at the scene's fps. The file's own rate, from the spacing
    of the keys (None when they already fall on whole frames)."""
    xs = sorted({round(kp.co.x, 4) for fc in act.fcurves for kp in fc.keyframe_points})
    if len(xs) < 3:
        return None
    step = min(b - a for a, b in itertools.pairwise(xs))
    if step <= 0 or abs(step - 1.0) < 1e-3:
        return None
    fps = bpy.context.scene.render.fps / step
    return fps if 1.0 <= fps <= 1000.0 else None


def _load(path, armature, action):
    _clear()
    _import(path)
    arm, act, arms, acts, notes = _choose(path, armature, action)
    if path.lower().endswith((".glb", ".gltf")):
        fps = _gltf_fps(arm, act)
        if fps is not None:  # import again at the file's rate, so that each sample is one frame
            _clear()
            bpy.context.scene.render.fps, bpy.context.scene.render.fps_base = round(fps), round(fps) / fps
            _import(path)
            arm, act, arms, acts, notes = _choose(path, armature, action)
    return arm, act, arms, acts, notes


def _scene_fps():
    r = bpy.context.scene.render
    return r.fps / r.fps_base


def _bake_object_motion(arm, act, start, end):
    """Move the armature object's own animation (``act``'s curves that are not a bone's) into its root bones, in
    armature space, and hold the object where it is at ``start``: the BVH exporter writes bones only, so object
    motion would be lost. Returns whether there was any."""
    own = [fc for fc in act.fcurves if not fc.data_path.startswith("pose.bones[")]
    if not any(abs(fc.evaluate(f) - fc.evaluate(start)) > 1e-6 for fc in own for f in range(start, end + 1)):
        return False  # no curves of its own, or still ones (an exporter's constant keys): nothing to carry
    scene, layer = bpy.context.scene, bpy.context.view_layer
    roots = [pb for pb in arm.pose.bones if pb.parent is None]
    scene.frame_set(start)
    first = arm.matrix_world.copy()
    posed = {}
    for f in range(start, end + 1):
        scene.frame_set(f)
        delta = first.inverted() @ arm.matrix_world
        posed[f] = {pb.name: delta @ pb.matrix for pb in roots}
    for fc in own:
        act.fcurves.remove(fc)
    arm.matrix_world = first
    for f in range(start, end + 1):
        scene.frame_set(f)
        for pb in roots:
            pb.matrix = posed[f][pb.name]
            layer.update()
            rot = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(pb.rotation_mode,
                                                                                              "rotation_euler")
            for path in ("location", rot):
                pb.keyframe_insert(path, frame=f, group=pb.name)
    return True


def _shift_keys(act, frames):
    """Move every key of ``act`` (its handles too) ``frames`` frames later."""
    for fc in act.fcurves:
        for kp in fc.keyframe_points:
            kp.co.x += frames
            kp.handle_left.x += frames
            kp.handle_right.x += frames
        fc.update()


def job_read(job):
    path = job["path"]
    arm, act, arms, acts, notes = _load(path, job.get("armature"), job.get("action"))
    return _read_action(job, path, arm, act, arms, acts, notes)


def _read_action(job, path, arm, act, arms, acts, notes):
    """:func:`job_read` once the armature and action are chosen: the action written as BVH (and the scene saved)."""
    start, end = _frame_range(act)
    if start < 0:  # Blender's scenes start at frame 0: the frames before it would be left out of the export
        _shift_keys(act, -start)
        notes.append(f"action {act.name!r} starts at frame {start}, before Blender's frame 0: all of it is read, "
                     f"and its result is keyed from frame 0 ({-start} frames later than the original)")
        start, end = 0, end - start
    if end <= start:
        raise JobError(f"{path}: action {act.name!r} of {arm.name!r} has one frame; nothing to style")
    limit = job.get("max_seconds")
    if limit and (end - start) / _scene_fps() > limit:  # before the export, which costs time and disk per frame
        raise JobError(f"{path}: action {act.name!r} runs from frame {start} to {end} ({(end - start) / _scene_fps() / 3600:.1f} "
                       f"hours at {_scene_fps():g} fps); clips up to {limit / 3600:g} hours are taken")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = start, end
    if _bake_object_motion(arm, act, start, end):
        notes.append(f"armature {arm.name!r} itself moves: its motion is carried by its root bone(s) (styled and "
                     "written back with the clip)")
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    bpy.context.view_layer.objects.active = arm
    arm.select_set(True)
    bpy.ops.export_anim.bvh(filepath=job["bvh"], frame_start=start, frame_end=end, rotate_mode="NATIVE",
                            root_transform_only=False, global_scale=1.0)
    meshes = [o.name for o in bpy.data.objects if o.type == "MESH" and o.find_armature() == arm]
    if job.get("blend"):  # the imported scene, for writing results back without importing the file again
        bpy.ops.file.pack_all()  # images the importer left outside (glTF's embedded ones) go along
        bpy.ops.wm.save_as_mainfile(filepath=job["blend"], copy=True, compress=False)
    return {"armature": arm.name, "armatures": arms, "action": act.name, "actions": acts, "notes": notes,
            "fps": _scene_fps(), "frame_start": start, "frame_end": end, "bones": len(arm.data.bones),
            "meshes": meshes}


def _build_armature(names, parents, offsets, ends):
    """A new armature from a BVH-like skeleton (armature space = the file's): each bone from its joint to
    its first child, else to its End Site, else along its parent's direction; roll 0."""
    data = bpy.data.armatures.new("Armature")
    arm = bpy.data.objects.new("Armature", data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    heads = []
    for j, p in enumerate(parents):
        heads.append(Vector(offsets[j]) + (heads[p] if p >= 0 else Vector()))
    children = {}
    for j, p in enumerate(parents):
        children.setdefault(p, []).append(j)
    bones = []
    for j, name in enumerate(names):
        b = data.edit_bones.new(name)
        b.head = heads[j]
        kids = children.get(j, [])
        direction = (heads[kids[0]] - heads[j]) if kids else None
        if direction is None and not any(math.isnan(x) for x in ends[j]):
            direction = Vector(ends[j])
        if direction is None or direction.length < 1e-6:
            direction = (heads[j] - heads[parents[j]]) * 0.5 if parents[j] >= 0 else Vector((0, 0, 0))
        if direction.length < 1e-6:
            direction = Vector((0.0, 0.1 * max(1e-3, max((h.length for h in heads), default=1.0)), 0.0))
        b.tail = heads[j] + direction
        b.roll = 0.0
        if parents[j] >= 0:
            b.parent = bones[parents[j]]
        bones.append(b)
    bpy.ops.object.mode_set(mode="OBJECT")
    return arm


def _key(arm, act_name, npz):
    """Key every bone of ``arm`` named in ``npz`` to its global transforms; returns the new action and its range."""
    names = [str(n) for n in npz["names"]]
    grot, gpos = npz["grot"], npz["gpos"]
    frames, start = grot.shape[0], int(npz["frame_start"])
    index = {n: i for i, n in enumerate(names)}
    bones = [b for b in arm.data.bones if b.name in index]
    if not bones:
        raise JobError(f"no bone of {arm.name!r} is in the styled clip")
    rest = {b.name: b.matrix_local.copy() for b in bones}
    rest_rot = {n: m.to_3x3() for n, m in rest.items()}
    action = bpy.data.actions.new(act_name)
    arm.animation_data_create()
    arm.animation_data.action = action
    posed = {}  # desired armature-space matrices of this frame
    keys = {b.name: [] for b in bones}
    previous = {}
    for t in range(frames):
        for b in bones:
            i = index[b.name]
            g = Quaternion(grot[t, i].tolist()).to_matrix()
            m = (g @ rest_rot[b.name]).to_4x4()
            m.translation = Vector(gpos[t, i].tolist())
            posed[b.name] = m
        for b in bones:
            m = posed[b.name]
            parent = b.parent
            if parent is not None and parent.name in posed:  # pose = parent's pose @ (parent rest^-1 @ rest) @ basis
                basis = rest[b.name].inverted() @ rest[parent.name] @ posed[parent.name].inverted() @ m
            else:  # the root, or a parent the clip does not move (it stays at rest)
                basis = rest[b.name].inverted() @ m
            loc, rot, _ = basis.decompose()
            pb = arm.pose.bones[b.name]
            if pb.rotation_mode == "QUATERNION":
                q = rot
                if b.name in previous and previous[b.name].dot(q) < 0:
                    q = -q
                previous[b.name] = q
                keys[b.name].append((loc, tuple(q)))
            elif pb.rotation_mode == "AXIS_ANGLE":
                axis, angle = rot.to_axis_angle()
                keys[b.name].append((loc, (angle, *axis)))
            else:
                e = rot.to_euler(pb.rotation_mode, previous.get(b.name))
                previous[b.name] = e
                keys[b.name].append((loc, tuple(e)))
    xs = numpy.arange(start, start + frames, dtype=numpy.float32)
    for b in bones:
        pb = arm.pose.bones[b.name]
        rot_path = {"QUATERNION": "rotation_quaternion", "AXIS_ANGLE": "rotation_axis_angle"}.get(pb.rotation_mode,
                                                                                               "rotation_euler")
        locs = numpy.array([k[0] for k in keys[b.name]], dtype=numpy.float32)
        rots = numpy.array([k[1] for k in keys[b.name]], dtype=numpy.float32)
        for path, values in (("location", locs), (rot_path, rots), ("scale", numpy.ones((frames, 3), numpy.float32))):
            # a channel still but for the float noise of the matrices it came from: one value (the exporter then
            # writes its two end keys, not one per frame; see FBX_SIMPLIFY)
            still = numpy.ptp(values, axis=0) < STILL * numpy.maximum(1.0, numpy.abs(values).max(axis=0))
            values = numpy.where(still, values[:1], values)
            for c in range(values.shape[1]):
                fc = action.fcurves.new(f'pose.bones["{b.name}"].{path}', index=c, action_group=b.name)
                fc.keyframe_points.add(frames)
                fc.keyframe_points.foreach_set("co", numpy.stack([xs, values[:, c]], 1).ravel())
                fc.keyframe_points.foreach_set("interpolation", numpy.full(frames, 1, dtype=numpy.int32))  # LINEAR
                fc.update()
    return action, start, start + frames - 1


def _rest_before(action, start):
    """Key the rest pose one frame before ``start`` and go there: Blender's FBX exporter writes the bones'
    node transforms (what an importer takes as the rest pose when no skin carries a bind pose) from the
    current frame; the baked animation covers ``start`` on only."""
    rest = {"location": 0.0, "scale": 1.0, "rotation_quaternion": (1.0, 0.0, 0.0, 0.0), "rotation_euler": 0.0,
            "rotation_axis_angle": (0.0, 0.0, 1.0, 0.0)}
    for fc in action.fcurves:
        value = rest[fc.data_path.rsplit(".", 1)[1]]
        fc.keyframe_points.insert(start - 1, value[fc.array_index] if isinstance(value, tuple) else value,
                                  options={"FAST"}).interpolation = "CONSTANT"
    for fc in action.fcurves:
        fc.update()
    bpy.context.scene.frame_set(start - 1)


# the FBX exporter's key simplification: keys that change a value by less than this x 1e-3 of its size are left
# out, so a channel the style did not change is two keys, not one per frame (a file comes back near its own size)
FBX_SIMPLIFY = 0.01
STILL = 1e-5  # a key channel whose values span less than this (relative to 1 or their size) is one value


def _embedded_gltf():
    """The glTF exporter's one-file .gltf format: Blender 4.2 offers it only once the add-on's preference allows it."""
    addon = bpy.context.preferences.addons.get("io_scene_gltf2")
    prefs = getattr(addon, "preferences", None)
    if prefs is not None and hasattr(prefs, "allow_embedded_format"):
        prefs.allow_embedded_format = True
    return "GLTF_EMBEDDED"


def _export(out, fmt, takes=False):
    """Export the scene as ``out``; ``takes``: each NLA strip (track, for glTF) of the armature as its own take."""
    if fmt == "fbx":
        with _TakesAtTheirFrames() if takes else contextlib.nullcontext():
            bpy.ops.export_scene.fbx(filepath=out, use_selection=False, add_leaf_bones=False, bake_anim=True,
                                     bake_anim_use_all_bones=True, bake_anim_use_nla_strips=takes,
                                     bake_anim_use_all_actions=False, bake_anim_force_startend_keying=True,
                                     bake_anim_simplify_factor=FBX_SIMPLIFY, apply_unit_scale=True)
    elif fmt in ("glb", "gltf"):
        bpy.ops.export_scene.gltf(filepath=out, export_format="GLB" if fmt == "glb" else _embedded_gltf(),
                                  export_animations=True, export_nla_strips=takes, export_force_sampling=True,
                                  export_frame_range=not takes, export_def_bones=False, export_skins=True,
                                  export_yup=True)
    else:
        raise JobError(f"{out}: expected format fbx, glb or gltf, got {fmt!r}")


def _keep_takes(arm, takes):
    """Each of ``takes`` ((action, name), the file's first first) in an NLA track and strip of its name, unmuted, at
    the action's own frames, and the first one active: the exporters' one-take-per-strip modes (FBX) and
    one-animation-per-track (glTF) then write the file's other actions as they were, beside the styled one."""
    data = arm.animation_data
    for track in list(data.nla_tracks):
        data.nla_tracks.remove(track)
    for act, name in takes:
        track = data.nla_tracks.new()
        track.name = name
        strip = track.strips.new(name, math.floor(act.frame_range[0] + 1e-6), act)
        strip.name = name
        strip.extrapolation = "NOTHING"
    data.action = takes[0][0]


class _TakesAtTheirFrames:
    """Blender's FBX exporter starts each strip's take at time 0; while this is entered each take keeps its own
    frames (as the file had them, and as the styled clip was read)."""

    def __enter__(self):
        import inspect

        from io_scene_fbx import export_fbx_bin

        self.module, self.do = export_fbx_bin, export_fbx_bin.fbx_animations_do
        signature = inspect.signature(self.do)
        if "start_zero" not in signature.parameters:
            return self
        do = self.do

        def at_own_frames(*args, **kwargs):
            bound = signature.bind(*args, **kwargs)
            bound.arguments["start_zero"] = False
            return do(*bound.args, **bound.kwargs)

        export_fbx_bin.fbx_animations_do = at_own_frames
        return self

    def __exit__(self, *exc):
        self.module.fbx_animations_do = self.do


def job_write(job):
    npz = numpy.load(job["motion"])
    fps = float(npz["fps"])
    takes = None
    if job.get("source"):
        if job.get("blend") and os.path.isfile(job["blend"]):
            bpy.ops.wm.open_mainfile(filepath=job["blend"])
            arm, act, _, names, _ = _choose(job["source"], job["armature"], job["action"])
        else:
            arm, act, _, names, _ = _load(job["source"], job.get("armature"), job.get("action"))
        name = act.name
        # the armature's actions in the file's order (the read's list: the file's first one first), the chosen one
        # to be replaced by the styled one (None here), the others written back as they were
        own = {a.name: a for a in _actions_for(arm)}
        order = [n for n in job.get("actions") or () if n in own] + [n for n in names if n not in (job.get("actions") or ())]
        takes = [(None if n == name else own[n], _take_name(arm, own[n])) for n in order]
        arm.animation_data.action = None
        bpy.data.actions.remove(act)  # the styled action takes its place (and its name)
    else:
        _clear()
        arm = _build_armature([str(n) for n in npz["names"]], npz["parents"].tolist(), npz["offsets"], npz["ends"].tolist())
        # the file's up axis turned to Blender's +Z (the exporters turn it back to their own convention)
        turn = {"+Z": (0, 0, 0), "-Z": (math.pi, 0, 0), "+Y": (math.pi / 2, 0, 0), "-Y": (-math.pi / 2, 0, 0),
                "+X": (0, -math.pi / 2, 0), "-X": (0, math.pi / 2, 0)}
        arm.rotation_euler = Euler(turn.get(job.get("up", "+Y"), (math.pi / 2, 0, 0)))
        name = job.get("name") or "Action"
    scene = bpy.context.scene
    if not job.get("source"):  # a file's own scene keeps its rate (the clip's frames are its frames)
        scene.render.fps, scene.render.fps_base = round(fps), round(fps) / fps
    action, start, end = _key(arm, name, npz)
    scene.frame_start, scene.frame_end = start, end
    several = takes is not None and (len(takes) > 1 or job["format"] != "fbx")
    if several:  # each action its own take (FBX) or animation (glTF), under the file's own names
        _keep_takes(arm, [(action if a is None else a, n) for a, n in takes])
    elif takes:  # one FBX take: named after the scene, so the source's take ("<armature>|<take>" read)
        scene.name = takes[0][1]
    if job["format"] == "fbx":
        arm.animation_data.action = action
        _rest_before(action, start)
    _export(job["out"], job["format"], takes=several)
    return {"armature": arm.name, "action": action.name, "frame_start": start, "frame_end": end, "fps": _scene_fps()}


def _what_failed(e):
    """``Type: message`` of an exception; for an operator's RuntimeError that carries an add-on's whole traceback
    ("Error: Python: Traceback ... OSError: [Errno 28] No space left on device"), the traceback's last line."""
    import re

    text = str(e)
    if "Traceback (most recent call last)" in text:
        raised = [ln.strip() for ln in text.splitlines() if re.match(r"\s*[A-Za-z_][\w.]*(Error|Exception)\b.*:", ln)]
        if raised:
            return raised[-1]
    return f"{type(e).__name__}: {text}"


def main():
    sys.stdout.write("V2S-READY\n")  # the caller's start-up limit ends here
    sys.stdout.flush()
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            job = json.loads(line)
            result = {"ok": True, **{"read": job_read, "write": job_write}[job["op"]](job)}
        except JobError as e:
            result = {"ok": False, "error": str(e)}
        except Exception as e:  # noqa: BLE001 - one line back to the caller, the job's file named there
            tb = traceback.format_exc().strip().splitlines()
            result = {"ok": False, "error": f"Blender: {_what_failed(e)}".strip(), "trace": tb[-6:]}
        sys.stdout.write("V2S-RESULT " + json.dumps(result) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
