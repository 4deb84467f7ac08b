"""Issue 51, item 8: an FBX result keeps its take's name and comes back near the input's size (a bone channel the
style left still is two keys, not one per frame). Needs Blender, as tests/test_interchange.py."""
import json
import subprocess
from pathlib import Path

import pytest

from testkit.clips import corpus_bvh, zero_style
from tests.helpers import needs_blender
from video2style import interchange
from video2style.cli import main
from video2style.interchange import Converter, blender_command

# a studio's file: one take named after the clip, exported with Blender's own default key simplification
RESAVE = r'''
import bpy, json, sys
job = json.loads(sys.argv[sys.argv.index("--") + 1])
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.fbx(filepath=job["path"])
bpy.data.actions[0].name = "jumping_jacks"
bpy.context.scene.name = "jumping_jacks"
bpy.ops.export_scene.fbx(filepath=job["out"], bake_anim=True, add_leaf_bones=False, bake_anim_use_nla_strips=False,
                         bake_anim_use_all_actions=False)
'''


def _resave(src: Path, out: Path) -> Path:
    cmd = blender_command()
    script = out.parent / "resave.py"
    out.parent.mkdir(parents=True, exist_ok=True)
    script.write_text(RESAVE)
    cmd = [*cmd[:-1], str(script)]
    env = None if "--python" not in cmd else interchange.blender_env()
    subprocess.run([*cmd, "--", json.dumps({"path": str(src), "out": str(out)})], check=True, capture_output=True,
                   timeout=300, env=env)
    return out


@pytest.mark.slow
@needs_blender
def test_an_fbx_result_keeps_its_take_name_and_about_its_size(tmp_path):
    with Converter() as conv:
        made = conv.write(corpus_bvh(tmp_path / "src", "mixamo", seconds=6.0), tmp_path / "made" / "walk.fbx")
    clip = _resave(made, tmp_path / "in" / "walk.fbx")
    out = tmp_path / "out"
    assert main(["apply", str(zero_style(tmp_path)), str(clip), "-o", str(out), "--no-preview"]) == 0
    with Converter() as conv:
        conv.to_bvh(clip)
        conv.to_bvh(out / "walk.fbx")
        before, after = conv.info(clip), conv.info(out / "walk.fbx")
    assert before["action"].endswith("|jumping_jacks")
    assert after["action"] == before["action"]  # not "<armature>|Scene"
    ratio = (out / "walk.fbx").stat().st_size / clip.stat().st_size
    assert ratio < 1.6, ratio  # 2.3 x when every channel was keyed on every frame
