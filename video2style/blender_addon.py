"""video2style for Blender: apply a style file to the selected armature's action, without the command line.

Install: Edit → Preferences → Add-ons → Install…, pick this file (``video2style/blender_addon.py`` in
the video2style package; ``python -c "import video2style, pathlib;
print(pathlib.Path(video2style.__file__).with_name('blender_addon.py'))"`` prints where). In the
add-on's preferences, set the ``video2style`` command if it is not on Blender's PATH (e.g. the one in
your virtual environment's ``bin/``).

Use: select an armature with an action, Object → Apply video2style style…, pick the ``.v2s`` file and
a strength. The add-on exports the action as BVH, runs ``video2style apply`` on it (a subprocess: the
models run in your Python, not Blender's), and keys the result onto the same armature as a new
action named ``<action>_<style>``; the original action is kept. Blender's own Python needs nothing.
"""
import os
import shutil
import subprocess
import tempfile

import bpy
from bpy.props import FloatProperty, StringProperty

bl_info = {
    "name": "video2style",
    "author": "video2style",
    "version": (0, 1, 0),
    "blender": (3, 0, 0),
    "location": "3D Viewport > Object > Apply video2style style",
    "description": "Apply a style learned from a video (video2style learn) to the selected armature's action",
    "category": "Animation",
}


class Video2StylePreferences(bpy.types.AddonPreferences):
    bl_idname = __name__
    executable: StringProperty(name="video2style command", default="video2style", subtype="FILE_PATH",
                               description="The video2style program (its full path if it is not on PATH)")

    def draw(self, context):
        self.layout.prop(self, "executable")


class _ReadModeWorkaround:
    """Blender 3.4's BVH importer opens files with mode 'rU', which Python 3.11 refuses (Debian's Blender)."""

    def __enter__(self):
        import builtins

        self._open = builtins.open
        builtins.open = lambda f, mode="r", *a, **k: self._open(f, mode.replace("U", ""), *a, **k)

    def __exit__(self, *exc):
        import builtins

        builtins.open = self._open


def _command(context) -> str:
    addon = context.preferences.addons.get(__name__)
    exe = addon.preferences.executable if addon else "video2style"
    found = shutil.which(exe) or (exe if os.path.isfile(exe) else None)
    if found is None:
        raise RuntimeError(f"cannot find the video2style command {exe!r}: set it in the add-on's preferences")
    return found


def _key_pose_from(target, source, frame_start: int, frame_end: int, action_name: str):
    """Key ``target``'s bones, frame by frame, to the world-space pose of the same-named bones of ``source``."""
    target.animation_data_create()
    original = target.animation_data.action
    action = bpy.data.actions.new(action_name)
    action.use_fake_user = True
    target.animation_data.action = action
    scene = bpy.context.scene
    bones = [pb for pb in target.pose.bones if pb.name in source.pose.bones]
    to_target = target.matrix_world.inverted() @ source.matrix_world
    for frame in range(frame_start, frame_end + 1):
        scene.frame_set(frame)
        for pb in bones:  # parents come first in pose.bones, so each child sees its parent's new pose
            pb.matrix = to_target @ source.pose.bones[pb.name].matrix
            bpy.context.view_layer.update()
            rot = "rotation_quaternion" if pb.rotation_mode == "QUATERNION" else (
                "rotation_axis_angle" if pb.rotation_mode == "AXIS_ANGLE" else "rotation_euler")
            pb.keyframe_insert(rot, frame=frame)
            pb.keyframe_insert("location", frame=frame)
    return original, action


class VIDEO2STYLE_OT_apply(bpy.types.Operator):
    """Apply a video2style style file to the active armature's action (kept); the result is a new action"""

    bl_idname = "video2style.apply_style"
    bl_label = "Apply video2style style"
    bl_options = {"REGISTER", "UNDO"}  # noqa: RUF012 - Blender's API reads this class attribute

    filepath: StringProperty(name="Style file", subtype="FILE_PATH", description="A .v2s file from video2style learn")
    filter_glob: StringProperty(default="*.v2s", options={"HIDDEN"})
    strength: FloatProperty(name="Strength", default=0.5, min=0.0, max=1.0,
                            description="0: the action unchanged; 0.5: twice the learned change (default); 1: four times")

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        return ob is not None and ob.type == "ARMATURE" and ob.animation_data is not None and ob.animation_data.action

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        arm = context.active_object
        action = arm.animation_data.action
        start, end = (round(f) for f in action.frame_range)
        if not os.path.isfile(self.filepath):
            self.report({"ERROR"}, f"{self.filepath}: no such style file")
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, 4)
        tmp = tempfile.mkdtemp(prefix="video2style-")
        scene_frame = context.scene.frame_current
        try:
            exe = _command(context)
            src = os.path.join(tmp, "content.bvh")
            bpy.ops.object.select_all(action="DESELECT")
            arm.select_set(True)
            context.view_layer.objects.active = arm
            bpy.ops.export_anim.bvh(filepath=src, frame_start=start, frame_end=end, rotate_mode="NATIVE",
                                    root_transform_only=False)
            wm.progress_update(1)
            self.report({"INFO"}, "video2style: applying the style (this takes a few seconds)")
            proc = subprocess.run([exe, "apply", self.filepath, src, "-o", os.path.join(tmp, "out"), "--strength",
                                   f"{self.strength:g}", "--no-preview"], check=False, capture_output=True, text=True)
            if proc.returncode != 0:
                lines = (proc.stderr or proc.stdout).strip().splitlines()
                self.report({"ERROR"}, f"video2style: {lines[-1] if lines else 'failed'}")
                return {"CANCELLED"}
            wm.progress_update(2)
            before = set(bpy.data.objects)
            with _ReadModeWorkaround():
                # Blender's exporter writes its own Z-up axes (video2style reads any up axis and keeps it):
                # read them back as they are
                bpy.ops.import_anim.bvh(filepath=os.path.join(tmp, "out", "content.bvh"), rotate_mode="NATIVE",
                                        frame_start=start, use_fps_scale=False, update_scene_fps=False,
                                        update_scene_duration=False, axis_forward="Y", axis_up="Z")
            result = next(o for o in bpy.data.objects if o not in before and o.type == "ARMATURE")
            wm.progress_update(3)
            style = os.path.splitext(os.path.basename(self.filepath))[0]
            _, new = _key_pose_from(arm, result, start, end, f"{action.name}_{style}")
            data, helper = result.data, result.animation_data.action
            bpy.data.objects.remove(result)
            bpy.data.armatures.remove(data)
            bpy.data.actions.remove(helper)
            bpy.ops.object.select_all(action="DESELECT")
            arm.select_set(True)
            context.view_layer.objects.active = arm
            wm.progress_update(4)
            self.report({"INFO"}, f"video2style: new action {new.name!r} on {arm.name} (the original is kept)")
            return {"FINISHED"}
        except Exception as e:  # noqa: BLE001 - shown to the user in Blender, one line
            self.report({"ERROR"}, f"video2style: {e}")
            return {"CANCELLED"}
        finally:
            context.scene.frame_set(scene_frame)
            wm.progress_end()
            shutil.rmtree(tmp, ignore_errors=True)


def _menu(self, context):
    self.layout.operator(VIDEO2STYLE_OT_apply.bl_idname, text="Apply video2style style…")


def register():
    bpy.utils.register_class(Video2StylePreferences)
    bpy.utils.register_class(VIDEO2STYLE_OT_apply)
    bpy.types.VIEW3D_MT_object.append(_menu)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(_menu)
    bpy.utils.unregister_class(VIDEO2STYLE_OT_apply)
    bpy.utils.unregister_class(Video2StylePreferences)
