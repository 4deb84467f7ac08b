"""Faults a studio pipeline meets: killed runs, full disks, name collisions, two runs on one folder,
untrusted style files (issue 14). Generated inputs only."""
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motioncore.bvh import write_bvh
from testkit.motions import random_motion
from tests.helpers import make_library, write_clip
from video2style import batch
from video2style.cli import main


def test_batch_outputs_never_collide_and_an_item_is_done_only_with_all_its_outputs(tmp_path, fake_pipeline):
    videos, content = make_library(tmp_path)
    out = tmp_path / "out"
    fake_pipeline["crash_after_bvh"].add("run.bvh")
    with pytest.raises(KeyboardInterrupt):
        batch.run_batch(videos, content, out, progress=lambda s: None)
    # clips named alike in two folders keep their folders
    assert (out / "old_mov" / "a" / "walk.bvh").is_file() and (out / "old_mov" / "b" / "walk.bvh").is_file()
    assert (out / "old_mov" / "run.bvh").is_file() and not (out / "old_mov" / "run_preview.mp4").exists()
    fake_pipeline["crash_after_bvh"].clear()
    fake_pipeline["apply"].clear()
    report = batch.run_batch(videos, content, out, progress=lambda s: None)
    redone = [Path(c).name for c in fake_pipeline["apply"]]
    assert redone.count("run.bvh") == 3  # the half-done item again, and the videos never reached
    assert (out / "old_mov" / "run_preview.mp4").is_file() and (out / "index.html").is_file()
    assert (out / "styles" / "old_mp4.v2s").is_file() and (out / "styles" / "old_mov.v2s").is_file()  # x.mp4, x.mov
    assert sum(r["status"] == "skipped (done)" for r in report.rows) == 2  # old_mov's two walks
    assert not report.failures


def test_a_corrupt_style_in_the_output_folder_is_learned_again(tmp_path, fake_pipeline):
    videos, content = make_library(tmp_path)
    out = tmp_path / "out"
    (out / "styles").mkdir(parents=True)
    (out / "styles" / "strut.v2s").write_bytes(b"\x00garbage")
    report = batch.run_batch(videos, content, out, progress=lambda s: None)
    assert "strut.mp4" in fake_pipeline["learn"] and not report.failures
    assert (out / "index.html").is_file()


def test_a_video_that_fails_is_one_failed_item_and_the_index_is_written(tmp_path, fake_pipeline, monkeypatch):
    videos, content = make_library(tmp_path)

    def broken(video, out, **kw):
        raise ValueError(f"{video}: no person found")

    monkeypatch.setattr("video2style.pipeline.learn_file", broken)
    out = tmp_path / "out"
    report = batch.run_batch(videos, content, out, progress=lambda s: None)
    assert len(report.failures) == 3 and "no person found" in (out / "index.html").read_text()


def test_stale_temporary_files_are_swept_and_a_second_batch_is_refused(tmp_path, fake_pipeline):
    videos, content = make_library(tmp_path)
    out = tmp_path / "out"
    (out / "old_mp4").mkdir(parents=True)
    stale = out / "old_mp4" / ".walk_preview.mp4.v2s-tmp-ab12cd34.mp4"  # motioncore.files.temp_beside's shape
    stale.write_bytes(b"x" * 100)
    mine = out / "old_mp4" / ".keep"  # a user's hidden file is not ours
    mine.write_text("x")
    with batch.folder_lock(out):
        with pytest.raises(RuntimeError, match="another batch is writing here"):
            batch.run_batch(videos, content, out, progress=lambda s: None)
        assert stale.exists()
    batch.run_batch(videos, content, out, progress=lambda s: None)
    assert not stale.exists() and mine.exists()


def test_apply_refuses_two_clips_that_would_write_one_output(tmp_path):
    from video2style.commands.apply import _bvh_inputs
    from video2style.commands.checks import CliError

    a, b = write_clip(tmp_path / "a" / "walk.bvh"), write_clip(tmp_path / "b" / "walk.bvh")
    with pytest.raises(CliError, match="would both write"):
        _bvh_inputs([a, b], tmp_path / "out")
    pairs = _bvh_inputs([tmp_path], tmp_path / "out")  # a folder keeps its subfolders
    assert sorted(str(w.relative_to(tmp_path / "out")) for _, w in pairs) == ["a", "b"]


def test_two_style_writers_do_not_share_a_temporary_file(tmp_path):
    from transfer.style_file import Style

    path = tmp_path / "s.v2s"
    styles = [Style({"w": torch.full((4, 4), float(i))}, {"style": f"s{i}"}, None) for i in range(2)]
    errors = []

    def save(s):
        try:
            for _ in range(20):
                s.save(path)
        except Exception as e:  # noqa: BLE001 - collected for the assertion
            errors.append(e)

    threads = [threading.Thread(target=save, args=(s,)) for s in styles]
    [t.start() for t in threads]
    [t.join() for t in threads]
    assert not errors and [p.name for p in tmp_path.iterdir()] == ["s.v2s"]


def test_a_video_writer_that_drops_frames_is_an_error_not_a_short_file(tmp_path, capsys, monkeypatch):
    import cv2

    real = cv2.VideoWriter

    class FullDisk:  # OpenCV on a full disk: write() fails silently after a while
        def __init__(self, *a):
            self.inner, self.n = real(*a), 0

        def isOpened(self):
            return self.inner.isOpened()

        def write(self, frame):
            self.n += 1
            if self.n <= 3:
                self.inner.write(frame)

        def release(self):
            self.inner.release()

    monkeypatch.setattr("motioncore.render.cv2.VideoWriter", FullDisk)
    clip, out = write_clip(tmp_path / "c.bvh"), tmp_path / "o" / "c.mp4"
    assert main(["preview", str(clip), "-o", str(out)]) == 1
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln]
    assert len(err) == 1 and str(out) in err[0] and "not written completely" in err[0]
    assert not out.exists() and not list(out.parent.iterdir())


def test_nan_never_reaches_a_file(tmp_path):
    m = random_motion(seconds=1.0)
    m.lrot[5, 3] = float("nan")
    with pytest.raises(ValueError, match="NaN"):
        write_bvh(tmp_path / "x.bvh", m)
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_sigterm_cleans_up_like_ctrl_c(tmp_path):
    clip = write_clip(tmp_path / "long.bvh", seconds=100.0)
    out = tmp_path / "o" / "long.mp4"
    proc = subprocess.Popen([sys.executable, "-m", "video2style", "preview", str(clip), "-o", str(out)],
                            stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.time() + 60
    while time.time() < deadline and not (out.parent.is_dir() and list(out.parent.iterdir())):
        time.sleep(0.1)  # wait until the temporary video exists
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "terminated" in err
    assert not out.exists() and not list(out.parent.iterdir())


# Untrusted style files: random metadata never gets past Style.load as anything but a one-line ValueError.
_JSON = st.recursive(st.none() | st.booleans() | st.integers(-10**9, 10**9) | st.floats(allow_nan=True) | st.text(max_size=20),
                     lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=12), kids, max_size=4),
                     max_leaves=12)


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(meta=st.dictionaries(st.sampled_from(["style", "content", "config", "iterations", "tempo", "rank",
                                              "base_model_sha256", "span", "loss_rec"]), _JSON, max_size=5),
       shape=st.lists(st.integers(1, 5), min_size=1, max_size=3),
       dtype=st.sampled_from([torch.float16, torch.float32, torch.int32]),
       bad=st.sampled_from(["none", "nan", "inf"]))
def test_fuzzed_style_files_are_refused_in_one_line_or_loaded(tmp_path_factory, meta, shape, dtype, bad):
    from safetensors.torch import save_file

    from transfer.style_file import Style

    path = tmp_path_factory.mktemp("fuzz") / "f.v2s"
    t = torch.ones(shape, dtype=dtype)
    if bad != "none" and dtype.is_floating_point:
        t.view(-1)[0] = float(bad)
    save_file({"blocks.0.ff2.lora_a": t}, str(path), metadata={"video2style": json.dumps(meta)})
    try:
        style = Style.load(path)
    except ValueError as e:
        msg = str(e)
        assert msg.startswith(str(path)) and "\n" not in msg
    else:  # whatever loads is sane
        assert all(torch.isfinite(v.float()).all() for v in style.adapters.values())
    assert os.path.exists(path)


@pytest.mark.slow
def test_a_frame_time_that_stretches_a_small_file_over_days_is_refused_before_resampling(tmp_path):
    from video2style.pipeline import read_clip

    clip = write_clip(tmp_path / "slow.bvh", seconds=2.0)
    text = clip.read_text().replace("Frame Time: 0.05000000", "Frame Time: 1.0")
    many = text.split("MOTION")[1].splitlines()[3:]
    body = text.split("MOTION")[0] + f"MOTION\nFrames: {len(many) * 600}\nFrame Time: 1.0\n" + "\n".join(many * 600) + "\n"
    clip.write_text(body)  # 24,000 frames of 1 s: 6.7 hours
    t0 = time.time()
    with pytest.raises(ValueError, match="hours long"):
        read_clip(clip)
    assert time.time() - t0 < 30


def test_a_crafted_field_name_with_a_newline_still_gives_one_line(tmp_path):
    """Found by the fuzz test on a fresh clone: an unknown config field named "\\n" split the error."""
    from safetensors.torch import save_file

    from transfer.style_file import Style

    path = tmp_path / "f.v2s"
    save_file({"blocks.0.ff2.lora_a": torch.ones(2)}, str(path), metadata={"video2style": json.dumps({"config": {"\n": 1}})})
    with pytest.raises(ValueError) as e:
        Style.load(path)
    assert str(e.value).startswith(str(path)) and "\n" not in str(e.value) and "unknown field" in str(e.value)
