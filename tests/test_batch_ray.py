"""batch --ray with a real local Ray: a bad video and a bad clip are reported while the rest finish, and a
worker killed in the middle of an apply task loses nothing (the task runs again; what was done is kept)."""
import json
import os
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason='Ray is not installed (pip install "video2style[ray]")')

SAMPLES = Path(__file__).resolve().parents[1] / "samples"


def _kill_an_apply_worker(stop: threading.Event, killed: list) -> None:
    while not stop.is_set() and not killed:
        pids = subprocess.run(["pgrep", "-f", "ray::_apply_job"], check=False, capture_output=True, text=True).stdout.split()
        if pids:
            time.sleep(0.5)  # let it finish an item or two first
            try:
                os.kill(int(pids[0]), signal.SIGKILL)
            except ProcessLookupError:  # its task ended meanwhile (a loaded machine): look for the next one
                continue
            killed.append(int(pids[0]))
        time.sleep(0.05)


def test_a_ray_batch_survives_a_killed_worker_and_reports_bad_inputs(tmp_path):
    from transfer.style_config import LearnConfig
    from video2style.batch_ray import run_batch_ray

    videos, content, out = tmp_path / "videos", tmp_path / "content", tmp_path / "out"
    videos.mkdir()
    (videos / "elderly.mp4").write_bytes((SAMPLES / "elderly.mp4").read_bytes())
    (videos / "broken.mp4").write_bytes(b"not a video")
    for name in ("walk_prior.bvh", "run_prior.bvh", "wave_right_hand_prior.bvh"):
        (content / "a").mkdir(parents=True, exist_ok=True)
        (content / "a" / name).write_text((SAMPLES / name).read_text())
    (content / "bad.bvh").write_text("HIERARCHY\nROOT x\n{\n")
    stop, killed = threading.Event(), []
    killer = threading.Thread(target=_kill_an_apply_worker, args=(stop, killed), daemon=True)
    killer.start()
    try:
        report = run_batch_ray(videos, content, out, learn_config=LearnConfig(iterations=25), workers=2, chunk=8,
                               progress=None)
    finally:
        stop.set()
    assert killed, "no apply worker was seen to kill"
    rows = json.loads((out / "report.json").read_text())
    by = {(r["video"], r.get("clip")): r for r in rows}
    assert by[("broken.mp4", None)]["status"] == "failed" and "learn" in by[("broken.mp4", None)]["error"]
    assert by[("elderly.mp4", "bad.bvh")]["status"] == "failed" and by[("elderly.mp4", "bad.bvh")]["attempts"] == 2
    for name in ("walk_prior", "run_prior", "wave_right_hand_prior"):
        assert by[("elderly.mp4", f"{name}.bvh")]["status"] in ("done", "skipped (done)")
        for suffix in (".bvh", "_preview.mp4", "_player.js"):
            assert (out / "elderly" / "a" / f"{name}{suffix}").is_file()
    assert not [p for p in out.rglob(".*") if p.is_file() and p.name != ".video2style.lock"]  # no temp files
    assert len(report.rows) == 5 and (out / "index.html").is_file()
