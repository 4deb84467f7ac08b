"""lifting.video: streaming frames and metadata, and its error messages."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lifting.video import iter_frames, video_info


def write_clip(path, n_frames, size=(64, 48), fps=25.0, fourcc="MJPG"):
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, size)
    assert writer.isOpened()
    for i in range(n_frames):
        writer.write(np.full((size[1], size[0], 3), 20 * i, np.uint8))  # brightness encodes the index
    writer.release()
    return path


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    return write_clip(tmp_path_factory.mktemp("video") / "clip.avi", 7)


def test_video_info(clip):
    fps, n, w, h = video_info(clip)
    assert fps == pytest.approx(25.0)
    assert (n, w, h) == (7, 64, 48)


def test_iter_frames_streams_in_order(clip):
    frames = iter_frames(clip)
    first = next(frames)  # an iterator, not a list
    rest = list(frames)
    indices = [first[0]] + [i for i, _, _ in rest]
    assert indices == list(range(7))
    times = [first[1]] + [t for _, t, _ in rest]
    np.testing.assert_allclose(times, np.arange(7) / 25.0)
    for i, _, frame in [first] + rest:
        assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8
        assert abs(float(frame.mean()) - 20 * i) < 4


def test_missing_file(tmp_path):
    missing = tmp_path / "nope.mp4"
    for fn in (video_info, iter_frames):
        with pytest.raises(ValueError, match="not found.*nope.mp4"):
            fn(missing)


def test_not_a_video(tmp_path):
    text = tmp_path / "notes.mp4"
    text.write_text("this is not a video\n")
    for fn in (video_info, iter_frames):
        with pytest.raises(ValueError, match="cannot open.*notes.mp4"):
            fn(text)


def test_zero_frames(tmp_path):
    empty = write_clip(tmp_path / "empty.avi", 0)
    with pytest.raises(ValueError, match="no readable frames.*empty.avi"):
        video_info(empty)
    with pytest.raises(ValueError, match="no readable frames.*empty.avi"):
        list(iter_frames(empty))


def test_messages_are_one_line(tmp_path):
    with pytest.raises(ValueError) as info:
        video_info(tmp_path / "missing.mp4")
    assert "\n" not in str(info.value)
