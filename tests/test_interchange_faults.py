"""Faults on the FBX/glTF route, its Blender child and the files around it (issue 53, "nothing lost, round 3"):
FBX/glTF outputs checked like BVH ones, locks that are links, glTF resources outside the file's folder, style
files that are not regular files, a misbehaving Blender (a fake one on PATH)."""
import json
import os
import sys
from pathlib import Path

import pytest

from testkit.clips import corpus_bvh, positions, zero_style
from tests.helpers import fake_apply, make_library, needs_blender, snapshot_tree, write_clip
from video2style import batch, interchange
from video2style.cli import main
from video2style.paths import LOCK_NAME


@pytest.fixture
def fake(fake_pipeline):  # conftest.py's fake learn/apply (calls recorded)
    return fake_pipeline


def _one_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


# 1. FBX/GLB outputs are checked like BVH ones, before any work.
@pytest.mark.parametrize("argv", [
    ["lib/walk.fbx", "-o", "lib/sub"],  # lib/sub/walk.fbx is the user's
    ["lib", "-o", "lib/sub"],
    ["src/walk.bvh", "-o", "lib/sub", "--format", "fbx"],
    ["src/walk.bvh", "-o", "lib/sub2", "--format", "glb"],
])
def test_a_users_fbx_or_glb_where_a_result_would_go_is_refused(tmp_path, monkeypatch, capsys, argv):
    fake_apply(monkeypatch)
    monkeypatch.chdir(tmp_path)
    lib = tmp_path / "lib"
    write_clip(tmp_path / "src" / "walk.bvh")
    lib.mkdir()
    (lib / "walk.fbx").write_bytes(b"Kaydara FBX Binary  \x00the input")
    (lib / "sub").mkdir()
    (lib / "sub" / "walk.fbx").write_bytes(b"the user's own clip")
    (lib / "sub2").mkdir()
    (lib / "sub2" / "walk.glb").write_bytes(b"the user's own clip")
    (tmp_path / "s.v2s").write_text("s")
    before = snapshot_tree(tmp_path)
    assert main(["apply", "s.v2s", *argv]) == 1
    err = _one_error(capsys)
    assert "would overwrite" in err and ("sub/walk.fbx" in err or "sub2/walk.glb" in err), err
    assert snapshot_tree(tmp_path) == before


def test_a_batch_over_a_users_fbx_in_a_result_folder_is_refused(tmp_path, fake):
    videos, content = make_library(tmp_path)
    (content / "walk.fbx").write_bytes(b"Kaydara FBX Binary  \x00")
    (content / "res" / "strut").mkdir(parents=True)
    (content / "res" / "strut" / "walk.fbx").write_bytes(b"the user's own clip")
    before = snapshot_tree(tmp_path)
    with pytest.raises(ValueError, match="res/strut/walk.fbx.*is a clip in the --content folder"):
        batch.run_batch(videos, content, content / "res", progress=lambda s: None)
    assert snapshot_tree(tmp_path) == before and fake["learn"] == []


def test_results_of_an_earlier_run_are_still_replaced(tmp_path, monkeypatch):
    fake_apply(monkeypatch)
    clip = write_clip(tmp_path / "in" / "walk.bvh")
    (tmp_path / "s.v2s").write_text("s")
    for _ in range(2):  # the folder holds our lock after the first run: its walk.bvh is ours
        assert main(["apply", str(tmp_path / "s.v2s"), str(clip), "-o", str(tmp_path / "out")]) == 0


# 2. A lock file that is a hard link is refused and its target never written.
def test_a_hard_link_planted_at_the_lock_is_refused_and_its_target_unchanged(tmp_path, monkeypatch, fake, capsys):
    fake_apply(monkeypatch)
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's file")
    clip = write_clip(tmp_path / "in" / "walk.bvh")
    (tmp_path / "s.v2s").write_text("s")
    out = tmp_path / "out"
    out.mkdir()
    os.link(victim, out / LOCK_NAME)
    assert main(["apply", str(tmp_path / "s.v2s"), str(clip), "-o", str(out)]) == 1
    err = _one_error(capsys)
    assert "hard links" in err and LOCK_NAME in err and victim.read_text() == "the user's file"
    videos, content = make_library(tmp_path)
    assert main(["batch", str(videos), "--content", str(content), "-o", str(out)]) == 1
    assert "hard links" in _one_error(capsys) and victim.read_text() == "the user's file" and fake["learn"] == []
    assert not (out / "walk.bvh").exists()


# 2b. A glTF's images and buffers outside its own folder are never read.
def _gltf(path: Path, uris: list[str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = {"asset": {"version": "2.0"}, "images": [{"uri": u} for u in uris],
           "buffers": [{"uri": "data:application/octet-stream;base64,AAAA", "byteLength": 3}]}
    path.write_text(json.dumps(doc))
    return path


def _glb(path: Path, uris: list[str]) -> Path:
    import struct

    body = json.dumps({"asset": {"version": "2.0"}, "images": [{"uri": u} for u in uris]}).encode()
    body += b" " * (-len(body) % 4)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"glTF" + struct.pack("<II", 2, 20 + len(body)) + struct.pack("<II", len(body), 0x4E4F534A) + body)
    return path


def test_gltf_resources_outside_the_files_folder_are_refused_before_blender(tmp_path, monkeypatch, capsys):
    (tmp_path / "sec").mkdir()
    (tmp_path / "sec" / "secret.png").write_bytes(b"secret")
    (tmp_path / "a" / "b" / "tex").mkdir(parents=True)
    (tmp_path / "a" / "b" / "tex" / "skin.png").write_bytes(b"png")
    (tmp_path / "a" / "b" / "out.png").symlink_to(tmp_path / "sec" / "secret.png")
    called = []
    monkeypatch.setattr(interchange.Blender, "call", lambda self, job, path: called.append(job) or {})
    for uri in ("../../sec/secret.png", str(tmp_path / "sec" / "secret.png"), "file:///etc/passwd",
                "%2E%2E/%2E%2E/sec/secret.png", "out.png"):
        for clip in (_gltf(tmp_path / "a" / "b" / "walk.gltf", ["tex/skin.png", uri]),
                     _glb(tmp_path / "a" / "b" / "walk.glb", [uri])):
            assert main(["skeleton", str(clip)]) == 1
            err = _one_error(capsys)
            assert str(clip) in err and "outside the file's folder" in err, err
    assert called == []
    assert interchange.outside_resources(_gltf(tmp_path / "a" / "b" / "ok.gltf", ["tex/skin.png", "tex/../tex/skin.png"])) == []


# 10b. A style file that is not a regular file is refused before it is opened.
def test_a_style_file_that_is_a_fifo_is_refused_before_open(tmp_path, capsys):
    import threading

    from transfer.style_file import Style

    fifo = tmp_path / "s.v2s"
    os.mkfifo(fifo)
    (tmp_path / "link.v2s").symlink_to(fifo)
    clip = write_clip(tmp_path / "in" / "walk.bvh")
    for style in (fifo, tmp_path / "link.v2s"):
        codes = []
        worker = threading.Thread(target=lambda s=style, codes=codes: codes.append(
            main(["apply", str(s), str(clip), "-o", str(tmp_path / "out")])), daemon=True)
        worker.start()
        worker.join(60)
        if worker.is_alive():  # hung in open(): give it a writer so that the thread ends, then fail
            with open(fifo, "wb"):
                pass
            pytest.fail("apply hung opening a FIFO")
        assert codes == [1]
        err = _one_error(capsys)
        assert str(style) in err and "FIFO" in err, err
    with pytest.raises(ValueError, match="is a folder, not a style file"):
        Style.load(tmp_path / "in")
    with pytest.raises(FileNotFoundError, match="no such style file"):
        Style.load(tmp_path / "none.v2s")
    assert not (tmp_path / "out" / "walk.bvh").exists()


# A fake `blender` that misbehaves as FAKE_BLENDER says (items 3, 4, 5, 7, 8, 9, 10).
FAKE = r'''#!{python}
import json, os, shutil, sys, time
mode = os.environ.get("FAKE_BLENDER", "")
if mode == "hang-start":
    time.sleep(300)
print("Blender 3.4.1 (fake)")
print("V2S-READY", flush=True)

def answer(obj):
    sys.stdout.write("V2S-RESULT " + (obj if isinstance(obj, str) else json.dumps(obj)) + "\n")
    sys.stdout.flush()

for line in sys.stdin:
    job = json.loads(line)
    p = job.get("path") or job.get("source") or ""
    if mode == "hang":
        time.sleep(300)
    if "bad" in os.path.basename(p):
        answer({"ok": False, "error": p + ": not an FBX file"})
        continue
    if mode == "no-fields":
        answer({"ok": True})
    elif mode == "no-error":
        answer({"ok": False})
    elif mode == "not-json":
        answer("{oops")
    elif mode == "esc":
        answer({"ok": False, "error": "\x1b[2J\x1b[31mEVIL\nsecond line"})
    elif mode == "flood":
        sys.stdout.write("x" * (40 << 20))
        sys.stdout.flush()
        sys.stderr.write("y" * (40 << 20) + "\n")
        sys.stderr.flush()
        time.sleep(300)
    elif mode == "truncated":
        sys.stdout.write('V2S-RESULT {"ok": false, "error": "No space left on device ... truncated')
        sys.stdout.flush()
        time.sleep(300)
    elif mode == "enospc":  # an add-on's traceback, as Blender's operators wrap it
        answer({"ok": False, "error": "Blender: RuntimeError: Error: Python: Traceback (most recent call last):\n"
                "  File \"export_bvh.py\", line 254, in write_armature\nOSError: [Errno 28] No space left on device"})
    elif mode == "nowrite" and job["op"] == "read":
        answer({"ok": True, "armature": "Armature", "action": "Walk", "fps": 30.0, "frame_start": 1, "frame_end": 30})
    elif job["op"] == "read":
        shutil.copyfile(os.environ["FAKE_BVH"], job["bvh"])
        answer({"ok": True, "armature": "Armature", "armatures": ["Armature"], "action": "Walk", "actions": ["Walk"],
                "notes": ["used armature '\x1b[2JArmature'"], "fps": 30.0, "frame_start": 1, "frame_end": 30,
                "bones": 22, "meshes": []})
    elif mode == "write-error":
        answer({"ok": False, "error": "Blender: PermissionError: cannot open " + job["out"]})
    else:
        open(job["out"], "wb").write(b"fbx")
        answer({"ok": True, "armature": "Armature", "action": "Walk", "frame_start": 1, "frame_end": 30, "fps": 30.0})
'''


@pytest.fixture
def fake_blender(tmp_path, monkeypatch):
    """``blender`` replaced by :data:`FAKE`; set ``FAKE_BLENDER`` for its mode. Returns a folder of clips."""
    exe = tmp_path / "bin" / "blender"
    exe.parent.mkdir()
    exe.write_text(FAKE.replace("{python}", sys.executable))
    exe.chmod(0o755)
    monkeypatch.setattr(interchange, "blender_command", lambda: [str(exe)])
    monkeypatch.setenv("FAKE_BVH", str(write_clip(tmp_path / "template.bvh")))
    clips = tmp_path / "clips"
    clips.mkdir()
    for name in ("a_bad.fbx", "b_walk.fbx", "c_run.glb"):
        (clips / name).write_bytes(b"Kaydara FBX Binary  \x00")
    return clips


def test_one_bad_clip_fails_alone(fake_blender, tmp_path):
    with interchange.Converter() as conv:
        with pytest.raises(interchange.InterchangeError, match="a_bad.fbx: not an FBX file"):
            conv.to_bvh(fake_blender / "a_bad.fbx")
        assert conv.to_bvh(fake_blender / "b_walk.fbx").is_file()
        assert conv.to_bvh(fake_blender / "c_run.glb").is_file()
        folder = conv._folder()
        assert len(list(folder.iterdir())) == 2  # the failed clip's temporary folder is gone
    assert not folder.exists()  # and all of it once the command ends


@pytest.mark.parametrize("mode, said", [("no-fields", "without armature, action, fps"),
                                        ("no-error", "a failure without its error"),
                                        ("not-json", "not JSON")])
def test_a_malformed_answer_is_one_line_naming_the_clip_and_blender(fake_blender, monkeypatch, capsys, mode, said):
    monkeypatch.setenv("FAKE_BLENDER", mode)
    clip = fake_blender / "b_walk.fbx"
    assert main(["skeleton", str(clip)]) == 1
    err = _one_error(capsys)
    assert str(clip) in err and "Blender" in err and said in err, err


def test_text_from_blender_or_a_style_file_is_printed_without_control_characters(fake_blender, tmp_path, monkeypatch,
                                                                               capsys):
    import torch
    from safetensors.torch import save_file

    monkeypatch.setenv("FAKE_BLENDER", "esc")
    assert main(["skeleton", str(fake_blender / "b_walk.fbx")]) == 1
    err = _one_error(capsys)
    assert "\x1b" not in err and "EVIL second line" in err
    monkeypatch.delenv("FAKE_BLENDER")
    with interchange.Converter(notify=lambda s: print(s, file=sys.stderr)) as conv:
        conv.to_bvh(fake_blender / "b_walk.fbx")
    note = capsys.readouterr().err
    assert "\x1b" not in note and "[2JArmature" in note
    style = tmp_path / "evil.v2s"
    meta = {"video2style": json.dumps({"style": "x"})}
    save_file({"\x1b[2J\x1b[31mEVIL.lora_a": torch.zeros(3, 5)}, str(style), metadata=meta)
    assert main(["apply", str(style), str(write_clip(tmp_path / "in" / "walk.bvh")), "-o", str(tmp_path / "out")]) == 1
    err = _one_error(capsys)
    assert "\x1b" not in err and str(style) in err, err


def test_a_result_blender_did_not_write_is_named_by_its_own_name(fake_blender, tmp_path, monkeypatch):
    monkeypatch.setenv("FAKE_BLENDER", "write-error")
    out = tmp_path / "out" / "walk.fbx"
    with interchange.Converter() as conv, pytest.raises(interchange.InterchangeError) as e:
        conv.write(fake_blender.parent / "template.bvh", out)
    assert f"cannot open {out}" in str(e.value) and ".v2s-tmp-" not in str(e.value), e.value
    assert not out.exists() and not list(out.parent.iterdir())


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["flood", "truncated", "hang-start"])
def test_a_flooding_or_silent_blender_is_bounded_and_stopped(fake_blender, monkeypatch, mode):
    import time

    monkeypatch.setenv("FAKE_BLENDER", mode)
    blender = interchange.Blender(timeout=6.0, startup=6.0)
    t0 = time.time()
    with pytest.raises(interchange.InterchangeError) as e:
        blender.call({"op": "read", "path": str(fake_blender / "b_walk.fbx")}, fake_blender / "b_walk.fbx")
    assert time.time() - t0 < 30 and blender._proc is None
    line = str(e.value)
    assert "\n" not in line and len(line) < 1000 and str(fake_blender / "b_walk.fbx") in line, line[:2000]
    if mode == "truncated":  # the answer without its newline is taken once Blender falls silent, not after the limit
        assert "truncated" in line and time.time() - t0 < 5.5


@pytest.mark.slow
def test_sigterm_while_blender_hangs_ends_at_once(fake_blender, tmp_path):
    import signal
    import subprocess
    import time

    exe = tmp_path / "bin" / "blender"
    env = {**os.environ, "FAKE_BLENDER": "hang", "VIDEO2STYLE_BLENDER": str(exe), "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "video2style", "skeleton", str(fake_blender / "b_walk.fbx")],
                            cwd=Path(__file__).resolve().parents[1], env=env, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(8)  # imports, then Blender asked
        t0 = time.time()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 143
        assert time.time() - t0 < 10
    finally:
        proc.kill()
        proc.wait()


# 7b. A span far past the end is one line, not an OverflowError.
@pytest.mark.parametrize("flag", ["--start", "--end"])
def test_a_span_of_1e308_seconds_is_one_line(tmp_path, capsys, flag):
    from motioncore.bvh import read_bvh
    from motioncore.motion import trim

    clip = write_clip(tmp_path / "walk.bvh")
    motion, _ = read_bvh(clip)
    if flag == "--end":
        assert trim(motion, (0.5, 1e308), "walk").num_frames == motion.num_frames - int(0.5 * motion.fps)
        return
    assert main(["learn", str(clip), flag, "1e308", "-o", str(tmp_path / "s.v2s")]) == 1
    err = _one_error(capsys)
    assert str(clip) in err and "select no frames" in err, err


def test_a_batch_report_holds_only_printable_text(fake_blender, tmp_path, monkeypatch, fake, capsys):
    monkeypatch.setenv("FAKE_BLENDER", "esc")
    monkeypatch.setattr(interchange, "_SHARED", [])
    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "v.mp4").write_bytes(b"not read by the fake learner")
    (videos / "w.mp4").write_bytes(b"not read by the fake learner")
    content = tmp_path / "content"
    content.mkdir()
    (content / "walk.fbx").write_bytes(b"Kaydara FBX Binary  \x00")
    from video2style import pipeline

    real_learn = pipeline.learn_file  # the fake pipeline's

    def learn_file(video, out, **kw):
        if Path(video).name == "w.mp4":
            raise ValueError(f"{video}: \x1b[2J\x1b[31mEVIL video")
        return real_learn(video, out, **kw)

    monkeypatch.setattr("video2style.pipeline.learn_file", learn_file)
    try:
        report = batch.run_batch(videos, content, tmp_path / "out", progress=print)
    finally:
        for conv in interchange._SHARED:
            conv.close()
    assert [r["status"] for r in report.rows] == ["failed", "failed"]
    assert "EVIL second line" in report.rows[0]["error"] and "EVIL video" in report.rows[1]["error"]
    assert "\x1b" not in report.table()
    assert "\x1b" not in capsys.readouterr().out


# 11. Temporary files and folders of failed or killed runs do not stay.
def test_apply_sweeps_what_an_interrupted_run_left_in_its_folders(tmp_path, monkeypatch, capsys):
    from motioncore.files import temp_beside

    fake_apply(monkeypatch)
    clip = write_clip(tmp_path / "in" / "walk.bvh")
    (tmp_path / "s.v2s").write_text("s")
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text("pid 1 apply")  # an earlier run's folder
    stale = [temp_beside(out / "long6.fbx"), temp_beside(out / "walk_preview.mp4")]
    users = out / ".notes.20241201.tmp"
    users.write_text("mine")
    assert main(["apply", str(tmp_path / "s.v2s"), str(clip), "-o", str(out)]) == 0
    assert not any(p.exists() for p in stale) and users.read_text() == "mine"
    assert "removed 2 temporary file(s)" in capsys.readouterr().err


def test_interchange_folders_of_killed_runs_are_removed(tmp_path, fake_blender, monkeypatch):
    import subprocess

    monkeypatch.setattr(interchange.tempfile, "tempdir", str(tmp_path))
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    left = tmp_path / f"{interchange.TEMP_PREFIX}{dead.pid}-abcd1234"
    (left / "0").mkdir(parents=True)
    alive = tmp_path / f"{interchange.TEMP_PREFIX}{os.getppid()}-abcd1234"  # a running process's: kept
    alive.mkdir()
    with interchange.Converter() as conv:
        conv.to_bvh(fake_blender / "b_walk.fbx")
        ours = conv._folder()
        assert ours.name.startswith(f"{interchange.TEMP_PREFIX}{os.getpid()}-")
    assert not left.exists() and alive.exists() and not ours.exists()


# 16. Small ones.
def test_an_empty_fbx_is_called_empty_and_named_once(fake_blender, tmp_path, capsys):
    clip = fake_blender / "empty.fbx"
    clip.write_bytes(b"")
    assert main(["skeleton", str(clip)]) == 1
    err = _one_error(capsys)
    assert "is empty (0 bytes)" in err and err.count("empty.fbx") == 1, err
    assert main(["skeleton", str(fake_blender / "a_bad.fbx")]) == 1  # Blender names the resolved path: said once
    err = _one_error(capsys)
    assert err.count("a_bad.fbx") == 1 and "not an FBX file" in err, err


def test_a_long_legal_clip_name_gets_a_temporary_name_that_fits(tmp_path, capsys):
    from motioncore.files import atomic_write_text, is_temp_name, temp_beside

    name = "w" * 240 + ".bvh"  # 244 characters: legal
    tmp = temp_beside(tmp_path / name)
    assert len(tmp.name) <= 255 and is_temp_name(tmp.name)
    atomic_write_text(tmp_path / ("é" * 120 + ".txt"), "x")  # 244 bytes of UTF-8
    too_long = "s" * 300 + ".v2s"
    assert main(["learn", str(write_clip(tmp_path / "walk.bvh")), "-o", str(tmp_path / too_long)]) == 1
    err = _one_error(capsys)
    assert "304 bytes long" in err and "[1/4]" not in capsys.readouterr().out  # refused before learning


def test_clips_of_one_name_in_one_folder_are_refused_for_the_right_reason(tmp_path, monkeypatch, capsys):
    fake_apply(monkeypatch)
    lib = tmp_path / "lib"
    lib.mkdir()
    for name in ("walk.fbx", "walk.glb"):
        (lib / name).write_bytes(b"x")
    (tmp_path / "s.v2s").write_text("s")
    assert main(["apply", str(tmp_path / "s.v2s"), str(lib), "-o", str(tmp_path / "out")]) == 1
    err = _one_error(capsys)
    assert "share the name 'walk' in one folder" in err and "give their folder" not in err, err


def test_a_video_named_styles_keeps_its_results_apart_from_the_style_files(tmp_path):
    keys = batch.video_keys([tmp_path / "styles.mp4", tmp_path / "walk.mp4"])
    assert keys[tmp_path / "styles.mp4"] != "styles" and keys[tmp_path / "walk.mp4"] == "walk"


ODD_OFFSETS = """HIERARCHY
ROOT Hips
{
  OFFSET 0.000000 90.000000 0.000000
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0.000000 123.456789 3.333333
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0.000000 10.000000 123.456789
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 0 0 0 0
1 90 0 0 5 0 0 5 0
"""


@pytest.mark.parametrize("units", ["cm", "auto", 0.0254])
def test_offsets_are_written_back_as_the_file_has_them(tmp_path, units):
    from motioncore.bvh import read_bvh, write_bvh

    src, out = tmp_path / "in.bvh", tmp_path / "out.bvh"
    src.write_text(ODD_OFFSETS)
    motion, layout = read_bvh(src, units=units)
    write_bvh(out, motion, layout)
    offsets = [ln.strip() for ln in ODD_OFFSETS.splitlines() if "OFFSET" in ln]
    assert [ln.strip() for ln in out.read_text().splitlines() if "OFFSET" in ln] == offsets  # not 9.999999
    moved = type(motion)(type(motion.skeleton)(motion.skeleton.names, motion.skeleton.parents,
                                               motion.skeleton.offsets * 2,
                                               {k: v * 2 for k, v in motion.skeleton.end_sites.items()}),
                         motion.lrot, motion.lpos, motion.fps)
    write_bvh(out, moved, layout)  # a skeleton changed since: its own offsets
    written = [[float(x) for x in ln.split()[1:]] for ln in out.read_text().splitlines() if "OFFSET" in ln]
    assert written[2][1:] == pytest.approx([20.0, 246.913578], abs=1e-4), written


# 10a, 12: files built with the real Blender.
ODD = r'''
import importlib.util, json, sys
import bpy
args = json.loads(sys.argv[sys.argv.index("--") + 1])
spec = importlib.util.spec_from_file_location("blender_io", args["blender_io"])
io = importlib.util.module_from_spec(spec); spec.loader.exec_module(io)
out = args["out"]
io._clear()
io._import(args["path"])
arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
prop = arm.copy()
prop.data = arm.data.copy()
prop.name = "Prop"
bpy.context.scene.collection.objects.link(prop)
prop.animation_data_clear()
prop.location.x += 2.0
bpy.ops.export_scene.fbx(filepath=out + "/prop.fbx", add_leaf_bones=False, bake_anim_use_nla_strips=False,
                         bake_anim_use_all_actions=False, bake_anim_force_startend_keying=False)
io._clear()
io._import(args["path"])
arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
pb = arm.pose.bones[0]
pb.rotation_mode = "QUATERNION"
pb.keyframe_insert("rotation_quaternion", frame=1080000)
bpy.ops.export_scene.gltf(filepath=out + "/long.glb", export_format="GLB", export_animations=True,
                          export_force_sampling=False, export_frame_range=False, export_nla_strips=False)
print("RESULT" + json.dumps({"ok": True}))
'''


@pytest.fixture(scope="module")
def odd_files(tmp_path_factory):
    import subprocess

    from tests.helpers import blender_problem

    if blender_problem() is not None:
        pytest.skip(f"no usable Blender: {blender_problem()}")
    folder = tmp_path_factory.mktemp("odd")
    with interchange.Converter() as conv:
        fbx = conv.write(corpus_bvh(folder / "src", "mixamo"), folder / "src" / "walk.fbx")
    helper = folder / "helper.py"
    helper.write_text(ODD)
    cmd = [*interchange.blender_command()[:-1], str(helper)]
    args = json.dumps({"path": str(fbx), "out": str(folder), "blender_io": str(interchange.SCRIPT)})
    env = None if "--python" not in cmd else interchange.blender_env()
    proc = subprocess.run([*cmd, "--", args], check=False, capture_output=True, text=True, timeout=300, env=env)
    assert "RESULT" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-2000:]
    return folder


@pytest.mark.slow
def test_an_armature_without_animation_is_refused_and_the_animated_one_taken(odd_files, capsys):
    clip = odd_files / "prop.fbx"
    assert main(["skeleton", str(clip), "--armature", "Prop"]) == 1
    err = _one_error(capsys)
    assert str(clip) in err and "'Prop' has no animation" in err, err
    assert main(["skeleton", str(clip)]) == 0  # one armature is animated: it is taken without asking
    assert "--armature to choose" in capsys.readouterr().err


@pytest.mark.slow
def test_an_action_of_days_is_refused_before_its_export(odd_files, capsys):
    import time

    clip = odd_files / "long.glb"
    t0 = time.time()
    assert main(["skeleton", str(clip)]) == 1
    err = _one_error(capsys)
    assert str(clip) in err and "hours" in err and "up to 6 hours" in err, err
    assert time.time() - t0 < 60


# 14b. A --rotate that turns an upright video is refused.
@pytest.mark.parametrize(("rotate", "seen_turn", "said"), [(180, 180, "leave --rotate out"), (90, 90, "leave --rotate out"),
                                                            (180, 270, "run again with --rotate 270")])
def test_a_rotate_that_turns_an_upright_video_is_refused(tmp_path, monkeypatch, rotate, seen_turn, said):
    from lifting import lift
    from tests.lifting.helpers import (
        fake_track,
        standing_landmarks,
        turned_pixels,
    )

    video = tmp_path / "upright.mp4"
    video.write_bytes(b"not decoded: the tracking is replaced")
    seen = fake_track(turned_pixels(standing_landmarks(), seen_turn))  # what the tracker sees in the turned frames
    monkeypatch.setattr(lift, "track", lambda *a, **k: seen)
    with pytest.raises(ValueError) as e:
        lift.lift_video(video, progress=lambda s: None, rotate=rotate)
    line = str(e.value)
    assert str(video) in line and f"--rotate {rotate} leaves the person" in line and said in line, line


@pytest.mark.parametrize("mode", ["nowrite", "enospc", "savez"])
def test_a_full_temporary_folder_is_called_full(fake_blender, monkeypatch, tmp_path, mode):
    import collections
    import shutil
    import tempfile

    import numpy as np

    monkeypatch.setenv("FAKE_BLENDER", mode)
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(1 << 30, 1 << 30, 4096))
    with interchange.Converter() as conv, pytest.raises(interchange.InterchangeError) as e:
        if mode == "savez":  # a BVH written as FBX: its motion handed to Blender through the full folder
            monkeypatch.setattr(np, "savez", lambda *a, **k: (_ for _ in ()).throw(OSError(28, "No space left on device")))
            conv.write(write_clip(tmp_path / "walk.bvh"), tmp_path / "out" / "walk.fbx")
        else:
            conv.to_bvh(fake_blender / "b_walk.fbx")
    line = str(e.value)
    assert ("walk.fbx" in line and "disk is full" in line and "TMPDIR" in line and "Traceback" not in line
            and f"in {tempfile.gettempdir()}:" in line), line


def test_an_add_ons_traceback_is_told_by_its_last_error(monkeypatch):
    import importlib.util
    import types

    for name in ("bpy", "mathutils"):  # blender_io outside Blender: only its text helpers are used
        monkeypatch.setitem(sys.modules, name, types.SimpleNamespace(Euler=None, Quaternion=None, Vector=None))
    spec = importlib.util.spec_from_file_location("blender_io_outside", interchange.SCRIPT)
    io = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(io)
    wrapped = RuntimeError("Error: Python: Traceback (most recent call last):\n  File \"export_bvh.py\", line 254, in "
                           "write_armature\n    file.write(x)\nOSError: [Errno 28] No space left on device\n\n"
                           "Location: /usr/share/blender/scripts/modules/bpy/ops.py:113")
    assert io._what_failed(wrapped) == "OSError: [Errno 28] No space left on device"
    assert io._what_failed(KeyError("fps")) == "KeyError: 'fps'"


def _in_blender(folder: Path, script: str, **args) -> dict:
    """Run the Blender-side ``script`` (its JSON argument: ``args`` and blender_io's path) in ``folder``; the JSON
    of the line it printed after ``RESULT``."""
    import subprocess

    folder.mkdir(parents=True, exist_ok=True)
    helper = folder / "helper.py"
    helper.write_text(script)
    cmd = [*interchange.blender_command()[:-1], str(helper)]
    env = None if "--python" not in cmd else interchange.blender_env()
    proc = subprocess.run([*cmd, "--", json.dumps({"blender_io": str(interchange.SCRIPT), **args})], check=False,
                          capture_output=True, text=True, timeout=300, env=env)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT")), None)
    assert line is not None, proc.stdout[-2000:] + proc.stderr[-2000:]
    return json.loads(line[len("RESULT"):])


# 14. An armature whose object moves: the motion is part of the clip.
MOVE = r"""
import importlib.util, json, sys
import bpy
args = json.loads(sys.argv[sys.argv.index("--") + 1])
spec = importlib.util.spec_from_file_location("blender_io", args["blender_io"])
io = importlib.util.module_from_spec(spec); spec.loader.exec_module(io)
io._clear()
io._import(args["path"])
arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
start, end = io._frame_range(arm.animation_data.action)
x0 = arm.location.x
for f, dx in ((start, 0.0), (end, 150.0)):  # the rig's units are centimetres: 1.5 m
    arm.location.x = x0 + dx
    arm.keyframe_insert("location", frame=f)
bpy.context.scene.frame_start, bpy.context.scene.frame_end = start, end
bpy.ops.export_scene.fbx(filepath=args["out"], add_leaf_bones=False, bake_anim_use_nla_strips=False,
                         bake_anim_use_all_actions=False)
print("RESULT" + json.dumps({"ok": True}))
"""


def _an_armature_that_moves_keeps_its_motion(tmp_path, conv, still):
    moved = tmp_path / "moved.fbx"
    _in_blender(tmp_path / "move", MOVE, path=str(still), out=str(moved))

    def travel(clip) -> float:  # metres the hips go along x, first frame to last
        _, p, _ = positions(conv.to_bvh(clip))
        return float(p[-1, 0, 0] - p[0, 0, 0])

    gained = travel(moved) - travel(still)
    assert abs(gained - 1.5) < 0.02, gained
    assert "itself moves" in " ".join(conv.info(moved)["notes"])
    written = conv.write(conv.to_bvh(moved), tmp_path / "out" / "moved.fbx", source=moved)  # written back
    assert abs(travel(written) - travel(moved)) < 0.01


# 15. Keys before frame 0 are read, with a note.
EARLY = r"""
import importlib.util, json, sys
import bpy
args = json.loads(sys.argv[sys.argv.index("--") + 1])
spec = importlib.util.spec_from_file_location("blender_io", args["blender_io"])
io = importlib.util.module_from_spec(spec); spec.loader.exec_module(io)
arm, act, arms, acts, notes = io._load(args["path"], None, None)
start, end = io._frame_range(act)
io._shift_keys(act, -11 - start)  # keys from frame -11 (a 240 fps file's, say)
info = io._read_action({"bvh": args["bvh"]}, args["path"], arm, act, arms, acts, notes)
print("RESULT" + json.dumps({"info": info, "frames": end - start + 1}))
"""


def _keys_before_frame_0_are_read_with_a_note(tmp_path, conv, fbx):
    from motioncore.bvh import read_bvh

    bvh = tmp_path / "early.bvh"
    out = _in_blender(tmp_path / "early", EARLY, path=str(fbx), bvh=str(bvh))
    assert read_bvh(bvh)[0].num_frames == out["frames"]  # none of the frames before 0 left out
    assert out["info"]["frame_start"] == 0 and any("starts at frame -11" in n for n in out["info"]["notes"])


@pytest.mark.slow
@needs_blender
@pytest.mark.parametrize("check", [_an_armature_that_moves_keeps_its_motion, _keys_before_frame_0_are_read_with_a_note],
                         ids=["14-the-armature-moves", "15-keys-before-frame-0"])
def test_a_clip_blender_made_is_read_whole(tmp_path, check):
    with interchange.Converter() as conv:
        fbx = conv.write(corpus_bvh(tmp_path / "src", "mixamo"), tmp_path / "src" / "walk.fbx")
        check(tmp_path, conv, fbx)


# 13. --action B: B is styled under its own name, the file's other actions kept as they were.
TAKES = r"""
import importlib.util, json, sys
import bpy
args = json.loads(sys.argv[sys.argv.index("--") + 1])
spec = importlib.util.spec_from_file_location("blender_io", args["blender_io"])
io = importlib.util.module_from_spec(spec); spec.loader.exec_module(io)
io._clear()
io._import(args["a"])
arm = next(o for o in bpy.data.objects if o.type == "ARMATURE")
first = set(bpy.data.objects)
io._import(args["b"])
walk_b = next(o for o in bpy.data.objects if o not in first and o.type == "ARMATURE").animation_data.action
for o in [o for o in bpy.data.objects if o not in first]:
    bpy.data.objects.remove(o)
walk_a = arm.animation_data.action
walk_a.name, walk_b.name = "WalkA", "WalkB"
for a in [a for a in bpy.data.actions if a not in (walk_a, walk_b)]:
    bpy.data.actions.remove(a)
arm.animation_data.action = None
for act in (walk_a, walk_b):  # a take (an animation) each, named after its strip (track)
    track = arm.animation_data.nla_tracks.new()
    track.name = act.name
    track.strips.new(act.name, int(act.frame_range[0]), act).name = act.name
bpy.ops.export_scene.fbx(filepath=args["out"] + "/takes.fbx", add_leaf_bones=False, bake_anim_use_nla_strips=True,
                         bake_anim_use_all_actions=False)
bpy.ops.export_scene.gltf(filepath=args["out"] + "/takes.glb", export_format="GLB", export_animations=True,
                          export_nla_strips=True)
print("RESULT" + json.dumps({"ok": True}))
"""


@pytest.mark.slow
@needs_blender
def test_the_chosen_action_is_styled_under_its_name_and_the_others_kept(tmp_path, capsys):
    from motioncore.bvh import write_bvh
    from motioncore.retarget import from_canonical, make_rig
    from testkit.motions import random_motion
    from testkit.rig_corpus import case

    rig = case("mixamo")
    for name, seed in (("a", 4), ("b", 7)):
        motion = from_canonical(random_motion(seconds=2.0, fps=30.0, seed=seed, amplitude=0.3), make_rig(rig.skeleton))
        write_bvh(tmp_path / f"{name}.bvh", motion, rig.layout)
    with interchange.Converter() as conv:
        made = {n: conv.write(tmp_path / f"{n}.bvh", tmp_path / f"{n}.fbx") for n in "ab"}
    _in_blender(tmp_path / "make", TAKES, a=str(made["a"]), b=str(made["b"]), out=str(tmp_path))
    style = zero_style(tmp_path, scale=0.5)  # a style that changes the motion
    for clip in (tmp_path / "takes.fbx", tmp_path / "takes.glb"):
        out = tmp_path / "out" / clip.suffix[1:]
        assert main(["apply", str(style), str(clip), "-o", str(out), "--no-preview", "--action", "WalkB"]) == 0, \
            capsys.readouterr().err
        printed = capsys.readouterr()
        assert "--action to choose" not in printed.out + printed.err  # chosen: no note that it could be
        assert main(["apply", str(style), str(clip), "-o", str(out / "bvh"), "--no-preview", "--action", "WalkB",
                     "--format", "bvh"]) == 0
        capsys.readouterr()
        result = out / clip.name

        def read(path, take):  # joint positions (metres) of one take
            with interchange.Converter(action=take) as conv:
                return positions(conv.to_bvh(path))[1], conv.info(path)

        a_in, info_in = read(clip, "WalkA")
        a_out, info = read(result, "WalkA")
        b_in, _ = read(clip, "WalkB")
        b_out, _ = read(result, "WalkB")
        styled = positions(out / "bvh" / clip.with_suffix(".bvh").name)[1]
        assert info["actions"] == info_in["actions"], (info["actions"], info_in["actions"])  # both, names kept
        assert a_out.shape == a_in.shape and float((a_out - a_in).abs().max()) < 1e-3  # WalkA as it was
        assert b_out.shape == b_in.shape and float((b_out - b_in).norm(dim=-1).mean()) > 0.01  # WalkB styled ...
        assert float((b_out - styled).abs().max()) < 2e-3  # ... as the BVH result is, frame for frame
        if clip.suffix == ".glb":  # the animations keep their names and order
            assert [a["name"] for a in interchange.gltf_json(result)["animations"]] == ["WalkA", "WalkB"]
