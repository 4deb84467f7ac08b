"""The tracking child of ``pose`` dies with its parent: ``kill -9`` of ``video2style pose`` while it tracks
leaves no process tracking on (issue 25; it used to run to the end of the video)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lifting.render_humanoid import frame_camera, render_frames
from motioncore.mp4 import write_mp4
from tests.lifting.helpers import H, W, waving_motion

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from Linux's /proc")


def _stat(pid: int) -> tuple[str, int] | None:
    """``(state, parent pid)`` of a process, None once it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    fields = text[text.rindex(")") + 2:].split()
    return fields[0], int(fields[1])


def _tracking_children(parent: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (st := _stat(int(entry.name))) and st[1] == parent:
            try:
                if b"lifting.track_process" in (entry / "cmdline").read_bytes():
                    found.append(int(entry.name))
            except OSError:
                continue
    return found


def _alive(pid: int) -> bool:
    st = _stat(pid)
    return st is not None and st[0] not in ("Z", "X")  # a zombie has stopped; only its parent's reaping is left


@pytest.mark.slow
def test_kill_9_of_pose_ends_its_tracking_child(blazepose_models, tmp_path):
    motion = waving_motion()
    cam = frame_camera(motion.global_positions().numpy(), 35.0, width=W, height=H)
    frames = list(render_frames(motion, cam))
    video = write_mp4(frames * 15, tmp_path / "long.mp4", 30.0, (W, H))  # 24 s: tracking takes a while
    pose = subprocess.Popen([sys.executable, "-m", "video2style", "pose", str(video), "-o", str(tmp_path / "o.bvh"),
                             "-q"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    children: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while not children and time.monotonic() < deadline and pose.poll() is None:
            children = _tracking_children(pose.pid)
            time.sleep(0.05)
        assert children, "pose started no tracking child"
        time.sleep(1.0)  # well into the tracking
        assert _alive(children[0])
        os.kill(pose.pid, signal.SIGKILL)
        pose.wait(timeout=10)
        gone_by = time.monotonic() + 2.0
        while _alive(children[0]) and time.monotonic() < gone_by:
            time.sleep(0.05)
        assert not _alive(children[0]), "the tracking child outlived its parent by 2 s"
    finally:
        if pose.poll() is None:
            pose.kill()
            pose.wait()
        for child in children:
            if _alive(child):
                os.kill(child, signal.SIGKILL)
    assert not (tmp_path / "o.bvh").exists()
