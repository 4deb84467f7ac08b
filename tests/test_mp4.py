"""motioncore.mp4: the one video writer (threaded encoding, frame count checked, temp file then rename)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from motioncore.mp4 import Mp4Writer, check_frame_count, write_mp4


def _frames(n: int, size=(64, 48)):
    for i in range(n):
        yield np.full((size[1], size[0], 3), 10 * i % 255, np.uint8)


def test_write_mp4_round_trip(tmp_path):
    out = write_mp4(_frames(12), tmp_path / "clip.mp4", 20.0, (64, 48))
    cap = cv2.VideoCapture(str(out))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 12
    assert (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))) == (64, 48)
    cap.release()
    assert [p.name for p in tmp_path.iterdir()] == ["clip.mp4"]


def test_a_failure_leaves_no_file(tmp_path):
    def broken():
        yield from _frames(3)
        raise RuntimeError("drawing failed")

    with pytest.raises(RuntimeError, match="drawing failed"):
        write_mp4(broken(), tmp_path / "clip.mp4", 20.0, (64, 48))
    assert list(tmp_path.iterdir()) == []


def test_a_frame_of_the_wrong_size_is_refused(tmp_path):
    with pytest.raises(ValueError, match="clip.mp4: expected a 48x64x3 uint8 frame, got 48x32x3 uint8"):
        write_mp4(_frames(2, (32, 48)), tmp_path / "clip.mp4", 20.0, (64, 48))
    with pytest.raises(ValueError, match="expected fps > 0"):
        Mp4Writer(tmp_path / "x.mp4", 0.0, (64, 48))


def test_a_short_file_is_reported_as_incomplete(tmp_path):
    out = write_mp4(_frames(5), tmp_path / "clip.mp4", 20.0, (64, 48))
    check_frame_count(out, 5)
    with pytest.raises(OSError, match=r"not written completely \(5 of 9 frames"):
        check_frame_count(out, 9, "final.mp4")
