"""Video -> canonical motion -> BVH and preview (``lifting.lift``, ``video2style.pose``).

Bad inputs that fail before any model is needed run everywhere; the rest needs the BlazePose
models (skipped cleanly without them, like the other tracker tests).
"""

from __future__ import annotations

import math
import subprocess
import sys

import cv2
import numpy as np
import pytest
import torch

from lifting.render_humanoid import frame_camera, write_humanoid_video
from motioncore.bvh import read_bvh
from motioncore.motion import Motion
from motioncore.representation import encode, facing_angle
from motioncore.skeleton import CANONICAL
from testkit.synthetic_blazepose import humanoid_frame
from tests.lifting.helpers import H, W, waving_motion

SK = CANONICAL.skeleton


def write_clip(path, frames) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (W, H))
    assert writer.isOpened()
    for f in frames:
        writer.write(f)
    writer.release()


def assert_nothing_written(folder, names=("out.bvh", "out_pose.mp4")) -> None:
    left = sorted(p.name for p in folder.iterdir() if p.name in names or p.name.startswith("."))
    assert left == [], left


# ---------------------------------------------------------------- bad inputs (no models needed)


def test_not_a_video(tmp_path):
    from video2style.pose import pose_file

    fake = tmp_path / "notes.mp4"
    fake.write_text("this is not a video\n")
    with pytest.raises(ValueError, match="cannot open.*notes.mp4") as info:
        pose_file(fake, tmp_path / "out.bvh", tmp_path / "out_pose.mp4", progress=False)
    assert "\n" not in str(info.value)
    assert_nothing_written(tmp_path)


def test_zero_frames(tmp_path):
    from video2style.pose import pose_file

    empty = tmp_path / "empty.avi"
    writer = cv2.VideoWriter(str(empty), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (W, H))
    writer.release()
    with pytest.raises(ValueError, match="empty.avi"):
        pose_file(empty, tmp_path / "out.bvh", tmp_path / "out_pose.mp4", progress=False)
    assert_nothing_written(tmp_path)


def test_missing_file(tmp_path):
    from lifting.lift import video_to_motion

    with pytest.raises(ValueError, match="not found.*nope.mp4"):
        video_to_motion(tmp_path / "nope.mp4")


def test_truncated_mp4_without_index(tmp_path):
    """OpenCV writes the mp4 index at the end: cut in half, the file cannot be opened."""
    from video2style.pose import pose_file

    whole = tmp_path / "whole.mp4"
    write_clip(whole, [humanoid_frame(W, H, 0.1 * i) for i in range(20)])
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    with pytest.raises(ValueError, match="cut.mp4"):
        pose_file(cut, tmp_path / "out.bvh", None, progress=False)
    assert_nothing_written(tmp_path)


# ---------------------------------------------------------------- with the models


@pytest.fixture(scope="module")
def rendered(tmp_path_factory, blazepose_models):
    """A 1.6 s 640x360 render of the waving humanoid, and its motion."""
    motion = waving_motion()
    cam = frame_camera(motion.global_positions().numpy(), 35.0, width=W, height=H)
    path = write_humanoid_video(motion, cam, tmp_path_factory.mktemp("render") / "wave.mp4")
    return path, motion


@pytest.mark.slow
def test_pose_file_writes_bvh_and_preview(rendered, tracker, tmp_path):
    from video2style.pose import pose_file

    video, truth = rendered
    lines = []
    summary = pose_file(video, tmp_path / "out.bvh", tmp_path / "out_pose.mp4", progress=lines.append, tracker=tracker)
    assert lines and all("frame" in line and "\n" not in line for line in lines)
    assert summary["frames"] == truth.num_frames and summary["tracked_frames"] == truth.num_frames
    assert summary["video_fps"] == pytest.approx(30.0) and summary["fps"] > 0
    motion, _ = read_bvh(tmp_path / "out.bvh")
    assert motion.skeleton.names == SK.names and motion.num_frames == summary["bvh_frames"] == truth.num_frames
    assert motion.fps == pytest.approx(30.0)
    torch.testing.assert_close(motion.skeleton.offsets, SK.offsets, atol=1e-5, rtol=0)
    # Preview: every video frame, the scaled frame beside a square skeleton panel.
    cap = cv2.VideoCapture(str(tmp_path / "out_pose.mp4"))
    n, w, h = (int(cap.get(p)) for p in (cv2.CAP_PROP_FRAME_COUNT, cv2.CAP_PROP_FRAME_WIDTH, cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    assert (n, h) == (truth.num_frames, 480) and w == 480 + round(W * 480 / H / 2) * 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.bvh", "out_pose.mp4"]  # no temporary files left


@pytest.mark.slow
def test_video_to_motion_accuracy_on_a_render(rendered, tracker):
    from lifting.lift import lift_video, video_to_motion

    video, truth = rendered
    lifted = lift_video(video, tracker=tracker)
    motion = lifted.motion
    assert motion.skeleton is SK and motion.fps == pytest.approx(30.0) and motion.num_frames == truth.num_frames
    pred = motion.global_positions().double().numpy()
    gt = truth.global_positions().double().numpy()
    from testkit.accuracy import compare

    m = compare(pred, gt, 30.0)
    assert m["pa_mpjpe_mm"] < 90.0, m
    assert m["min_foot_m"] >= 0.0  # no foot below the floor
    theta = facing_angle(torch.from_numpy(pred[:15]))
    assert abs(math.degrees(float(torch.atan2(torch.sin(theta).mean(), torch.cos(theta).mean())))) < 5.0  # faces +Z
    np.testing.assert_allclose(pred[0, 0, [0, 2]], 0.0, atol=1e-5)  # starts at x = z = 0
    assert np.abs(pred[:, 0, [0, 2]]).max() < 0.3  # standing: the path stays near the start
    assert encode(motion).shape[0] == motion.num_frames  # the representation accepts it
    # The unfiltered lift of the same landmarks is jerkier.
    from lifting.reconstruct import lift_track

    raw = lift_track(lifted.track, str(video), cutoff_hz=None).motion.global_positions().double().numpy()
    assert compare(raw, gt, 30.0)["jitter"] > m["jitter"]
    assert isinstance(video_to_motion(video, tracker=tracker), Motion)


@pytest.mark.slow
def test_grey_video_has_no_person(tracker, tmp_path):
    from video2style.pose import pose_file

    grey = tmp_path / "grey.mp4"
    write_clip(grey, [np.full((H, W, 3), 128, np.uint8)] * 10)
    with pytest.raises(ValueError, match=r"grey.mp4: no person found in any of the 10 frames"):
        pose_file(grey, tmp_path / "out.bvh", tmp_path / "out_pose.mp4", progress=False, tracker=tracker)
    assert_nothing_written(tmp_path)


@pytest.mark.slow
def test_too_little_motion(tracker, tmp_path):
    from video2style.pose import pose_file

    short = tmp_path / "short.mp4"
    write_clip(short, [humanoid_frame(W, H, 0.2 * i) for i in range(12)] + [np.full((H, W, 3), 128, np.uint8)] * 30)
    with pytest.raises(ValueError, match=r"short.mp4: too little usable motion.*12 frames"):
        pose_file(short, tmp_path / "out.bvh", None, progress=False, tracker=tracker)
    assert_nothing_written(tmp_path)


def test_truncated_avi(tracker, tmp_path):
    """An AVI cut in half still opens; it decodes fewer frames than its header lists."""
    from video2style.pose import pose_file

    whole = tmp_path / "whole.avi"
    writer = cv2.VideoWriter(str(whole), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (W, H))
    for i in range(40):
        writer.write(humanoid_frame(W, H, 0.2 * i))
    writer.release()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    with pytest.raises(ValueError, match=r"cut.avi: the video looks truncated"):
        pose_file(cut, tmp_path / "out.bvh", tmp_path / "out_pose.mp4", progress=False, tracker=tracker)
    assert_nothing_written(tmp_path)


def test_short_gaps_are_interpolated(rendered, tracker, tmp_path):
    from lifting.reconstruct import lift_track
    from lifting.tracking import track

    video, truth = rendered
    result = track(video, tracker=tracker)
    result.found[10:14] = False  # a 4-frame dropout
    result.world[10:14] = np.nan
    lifted = lift_track(result, str(video))
    assert (lifted.start, lifted.stop, lifted.filled) == (0, truth.num_frames, 4)
    assert torch.isfinite(lifted.motion.lrot).all() and torch.isfinite(lifted.motion.lpos).all()


def test_the_tracking_side_imports_no_torch():
    """torch (~1 s) is imported on a thread while frames are tracked, so the tracking side must not need it."""
    code = "import sys, lifting.lift, video2style.pose; print(sorted(m for m in ('torch', 'kornia') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    assert out.strip() == "[]"


def test_the_background_import_hands_its_error_to_the_caller():
    from lifting import preload

    preload.start("no_such_module_v2s")
    with pytest.raises(ModuleNotFoundError, match="no_such_module_v2s"):
        preload.finish("no_such_module_v2s")
    preload.start("json")  # already imported: no thread
    assert "json" not in preload._threads and preload.finish("json").dumps([1]) == "[1]"


@pytest.mark.slow
def test_tracking_in_a_child_process_matches_tracking_here(rendered, tracker, tmp_path, monkeypatch):
    from lifting import track_process
    from lifting.track_process import track_in_child
    from lifting.tracking import track

    for span in ((None, None), (0.5, None)):
        here, there = track(rendered[0], tracker=tracker, span=span), track_in_child(rendered[0], span=span)
        for name in ("world", "image", "visibility", "presence", "score", "found", "times"):
            np.testing.assert_array_equal(getattr(there, name), getattr(here, name), err_msg=name)
        assert (there.fps, there.width, there.height) == (here.fps, here.width, here.height)
    with pytest.raises(ValueError, match=r"^video file not found: .*nope\.mp4$"):
        track_in_child(tmp_path / "nope.mp4")
    monkeypatch.setattr(sys, "executable", "/bin/false")  # not a Python: no reply
    with pytest.raises(track_process.ChildFailedError, match="without a result"):
        track_in_child(rendered[0])


def test_lift_video_tracks_in_a_child_only_while_torch_is_still_loading(monkeypatch, tmp_path):
    """A fresh process (the torch side not imported yet) tracks in a child; a given tracker, a progress callback
    or an already imported torch side keep the tracking here."""
    import types

    from lifting import lift, preload, track_process

    calls = []
    fake = types.SimpleNamespace(lift_track=lambda result, *a, **k: types.SimpleNamespace(info={}))
    monkeypatch.setattr(preload, "start", lambda name: None)
    monkeypatch.setattr(preload, "finish", lambda name: fake)
    monkeypatch.setattr(track_process, "track_in_child", lambda *a: calls.append("child") or "a track")
    monkeypatch.setattr(lift, "track", lambda *a: calls.append("here") or "a track")
    monkeypatch.setattr(lift, "check_upright", lambda *a: None)
    monkeypatch.delitem(sys.modules, preload.RECONSTRUCT, raising=False)
    lift.lift_video(tmp_path / "v.mp4", progress=True)
    lift.lift_video(tmp_path / "v.mp4", progress=print)
    lift.lift_video(tmp_path / "v.mp4", tracker=object())
    def no_reply(*a):
        calls.append("child failed")
        raise track_process.ChildFailedError("no reply")

    monkeypatch.setattr(track_process, "track_in_child", no_reply)
    lift.lift_video(tmp_path / "v.mp4")  # a child that cannot run: tracked here instead
    monkeypatch.setitem(sys.modules, preload.RECONSTRUCT, fake)
    lift.lift_video(tmp_path / "v.mp4")
    assert calls == ["child", "here", "here", "child failed", "here", "here"]


def test_the_child_hands_back_a_missing_model_error(tmp_path, monkeypatch):
    from lifting.blazepose.assets import CACHE_ENV, WHEEL_ENV, ModelUnavailableError
    from lifting.track_process import track_in_child

    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "empty-cache"))
    monkeypatch.setenv(WHEEL_ENV, str(tmp_path / "no-such.whl"))  # offline: no download is tried
    with pytest.raises(ModelUnavailableError, match="no-such.whl"):
        track_in_child(tmp_path / "v.mp4")
