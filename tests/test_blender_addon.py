"""The Blender add-on, in Debian's Blender run headless: a style file applied to an armature's action."""
import copy
import json
import shutil
import subprocess
from pathlib import Path

import pytest
import torch

BLENDER = shutil.which("blender")
ADDON = Path(__file__).resolve().parents[1] / "video2style" / "blender_addon.py"

SCRIPT = r'''
import builtins, json, sys
import bpy
args = json.loads(sys.argv[sys.argv.index("--") + 1])
_open = builtins.open
builtins.open = lambda f, mode="r", *a, **k: _open(f, mode.replace("U", ""), *a, **k)
bpy.ops.import_anim.bvh(filepath=args["clip"], rotate_mode="NATIVE", update_scene_duration=True)
builtins.open = _open
arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
original = arm.animation_data.action
bpy.ops.preferences.addon_install(filepath=args["addon"])
bpy.ops.preferences.addon_enable(module="blender_addon")
bpy.context.preferences.addons["blender_addon"].preferences.executable = args["exe"]
bpy.context.view_layer.objects.active = arm
arm.select_set(True)
def positions(action):
    arm.animation_data.action = action
    out = []
    for f in (1, 15, 30):
        bpy.context.scene.frame_set(f)
        out.append([list(arm.matrix_world @ pb.head) for pb in arm.pose.bones])
    return out
before = positions(original)
arm.animation_data.action = original
result = bpy.ops.video2style.apply_style(filepath=args["style"], strength=0.5)
new = arm.animation_data.action
print("RESULT" + json.dumps({"result": list(result), "original": original.name, "new": new.name,
      "actions": [a.name for a in bpy.data.actions], "armatures": [o.name for o in bpy.data.objects if o.type == "ARMATURE"],
      "before": before, "after": positions(new)}))
'''


@pytest.mark.slow
@pytest.mark.skipif(BLENDER is None, reason="no Blender here (Debian: apt install blender)")
def test_the_addon_keys_a_styled_copy_of_the_action(tmp_path):
    from motioncore.bvh import write_bvh
    from motioncore.retarget import from_canonical, make_rig
    from testkit.motions import random_motion
    from testkit.rig_corpus import case
    from transfer.bundle import load_models
    from transfer.lora import add_lora, lora_state
    from transfer.style_file import Style
    from video2style.paths import console_script

    c = case("mixamo")
    clip = tmp_path / "walk.bvh"
    write_bvh(clip, from_canonical(random_motion(seconds=2.0, fps=30.0, seed=4, amplitude=0.3), make_rig(c.skeleton)), c.layout)
    model = copy.deepcopy(load_models().prior)
    add_lora(model, rank=8)  # a style of zero adapters: the style model is the prior, the result the content
    style = tmp_path / "zero.v2s"
    Style({k: torch.zeros_like(v) for k, v in lora_state(model).items()}, {"style": "zero", "rank": 8}).save(style)
    exe = str(console_script())
    script = tmp_path / "run.py"
    script.write_text(SCRIPT)
    args = json.dumps({"clip": str(clip), "addon": str(ADDON), "exe": exe, "style": str(style)})
    proc = subprocess.run([BLENDER, "-b", "--factory-startup", "--python", str(script), "--", args],
                          check=False, capture_output=True, text=True, timeout=300)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT")), None)
    assert line is not None, proc.stdout[-2000:] + proc.stderr[-2000:]
    out = json.loads(line[len("RESULT"):])
    assert out["result"] == ["FINISHED"] and out["new"] == f"{out['original']}_zero"
    assert sorted(out["actions"]) == sorted([out["original"], out["new"]]) and len(out["armatures"]) == 1  # no helpers left
    before, after = torch.tensor(out["before"]), torch.tensor(out["after"])
    assert before.shape == after.shape
    assert float((before - after).norm(dim=-1).max()) < 3.0  # cm: a zero style leaves the motion (feet cleaned)
