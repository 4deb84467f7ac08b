"""A long BVH take a span of frames at a time: :class:`BvhFrames` scans the file once for where each frame line
starts and then parses any span of frames; :class:`BvhSpanWriter` writes a take span by span, atomically (a
temporary file renamed at the end, nothing left on failure). Memory grows with the span, not the take."""
from __future__ import annotations

import contextlib
import dataclasses
import os
from pathlib import Path

import numpy as np

from motioncore.bvh import (
    _MOTION_LINE,
    MAX_MAGNITUDE,
    BvhError,
    BvhLayout,
    _assemble,
    _decode,
    _header,
    _motion_block,
    _numbers,
    _parse_hierarchy,
    _Reader,
    _rows,
)
from motioncore.files import atomic_output
from motioncore.motion import Motion

_SCAN = 1 << 24  # bytes read at a time while looking for frame lines


class BvhFrames:
    """The frames of a BVH file, read a span at a time: ``BvhFrames(path)[a:b]`` is the :class:`Motion` of frames
    ``a..b-1`` (as :func:`motioncore.bvh.read_bvh` reads them, with the same skeleton and units), ``layout``
    the file's layout, ``num_frames`` and ``fps`` the take's. Raises :class:`BvhError` naming the file on a
    malformed header, a frame count that does not match the lines, or (when a span is read) bad numbers."""

    def __init__(self, path: str | os.PathLike, units: str | float = "auto"):
        self.path = os.fspath(path)
        if os.path.isdir(self.path):
            raise BvhError(f"{self.path}: is a folder, not a BVH file")
        try:
            head, body_start = self._header_text()
            text, encoding = _decode(head)
            self._hierarchy = _parse_hierarchy(_Reader(self.path, text.removeprefix("\ufeff")))
            self._channels = sum(len(c) for c in self._hierarchy[3])
            _, self._frame_time, n, self._frame_time_text = _motion_block(self.path, text.replace("\r\n", "\n"),
                                                                          self._channels, declared_only=True)
            self.starts = self._scan(body_start)  # (frames + 1,) byte offsets; the last: the end of the file
        except OSError as e:
            raise BvhError(f"{self.path}: cannot read: {e.strerror or e}") from None
        if len(self.starts) - 1 != n:
            raise BvhError(f"{self.path}: declared {n} frames, found {len(self.starts) - 1}")
        self.num_frames = n
        self._units = units
        first, layout = _assemble(self._hierarchy, self._parse(0, 1), self._frame_time, self._frame_time_text, units)
        self.skeleton, self.fps = first.skeleton, first.fps
        self.layout = dataclasses.replace(layout, encoding=encoding)

    @staticmethod
    def declared(path: str | os.PathLike) -> tuple[int, float]:
        """``(frames, frame_time)`` as the file's header declares them, the frames not read."""
        self = BvhFrames.__new__(BvhFrames)
        self.path = os.fspath(path)
        try:
            head, _ = self._header_text()
        except OSError as e:
            raise BvhError(f"{self.path}: cannot read: {e.strerror or e}") from None
        text, _ = _decode(head)
        hierarchy = _parse_hierarchy(_Reader(self.path, text.removeprefix("\ufeff")))
        _, frame_time, n, _ = _motion_block(self.path, text.replace("\r\n", "\n"), sum(len(c) for c in hierarchy[3]),
                                            declared_only=True)
        return n, frame_time

    def _header_text(self) -> tuple[bytes, int]:
        """The bytes up to and with the "Frame Time:" line, and the offset where the frame lines begin."""
        with open(self.path, "rb") as f:
            lines, after_motion = [], 0
            for raw in f:
                lines.append(raw)
                line = raw.decode("latin-1")
                if after_motion or _MOTION_LINE.match(line.rstrip("\r\n")):
                    after_motion += bool(line.strip())
                    if after_motion == 3:  # MOTION, Frames:, Frame Time:
                        head = b"".join(lines)
                        return head, len(head)
        raise BvhError(f"{self.path}: missing MOTION section with 'Frames:' and 'Frame Time:'")

    def _scan(self, offset: int) -> np.ndarray:
        """Byte offsets of the non-blank lines from ``offset`` on, and the file's size after them."""
        found = []
        with open(self.path, "rb") as f:
            f.seek(offset)
            pos, line_start, blank = offset, offset, True
            while True:
                chunk = f.read(_SCAN)
                if not chunk:
                    break
                arr = np.frombuffer(chunk, dtype=np.uint8)
                ends = np.flatnonzero(arr == 10)  # newlines
                space = np.isin(arr, (9, 10, 13, 32))
                # a line is blank when nothing between its start and its newline is other than whitespace
                nonspace = np.concatenate(([0], np.cumsum(~space)))
                bounds = np.concatenate(([line_start - pos], ends + 1))
                for k in range(len(ends)):
                    lo, hi = max(0, bounds[k]), bounds[k + 1]
                    if not (blank and nonspace[hi] - nonspace[lo] == 0):
                        found.append(line_start)
                    line_start, blank = pos + hi, True
                tail_lo = max(0, bounds[-1])
                blank = blank and nonspace[len(arr)] - nonspace[tail_lo] == 0
                pos += len(arr)
            if not blank:
                found.append(line_start)
        return np.asarray(found + [pos], dtype=np.int64)

    def _parse(self, a: int, b: int) -> np.ndarray:
        with open(self.path, "rb") as f:
            f.seek(int(self.starts[a]))
            raw = f.read(int(self.starts[b] - self.starts[a]))
        data = _numbers(raw.decode("ascii", errors="replace"))
        if data is None or data.size != (b - a) * self._channels:
            raise self._bad_line(raw, a, b)
        if not np.isfinite(data).all():
            raise BvhError(f"{self.path}: frame data holds NaN or infinite values")
        if data.size and np.abs(data).max() > MAX_MAGNITUDE:
            raise BvhError(f"{self.path}: frame data holds values of magnitude above {MAX_MAGNITUDE:g}")
        return data.reshape(b - a, self._channels)

    def _bad_line(self, raw: bytes, a: int, b: int) -> BvhError:
        """The error for frames ``a..b-1`` (their bytes ``raw``), which hold a frame that is not ``_channels``
        numbers: it names the file's line, as :func:`motioncore.bvh.read_bvh` does."""
        base = int(self.starts[a])
        for i in range(a, b):
            row = raw[int(self.starts[i]) - base:int(self.starts[i + 1]) - base].decode("ascii", errors="replace")
            values = _numbers(row)
            if values is None:
                return BvhError(f"{self.path}:{self._line_of(int(self.starts[i]))}: expected numbers in the frame data")
            if values.size != self._channels:
                return BvhError(f"{self.path}:{self._line_of(int(self.starts[i]))}: expected {self._channels} values "
                                f"per frame, got {values.size}")
        return BvhError(f"{self.path}: frames {a + 1}-{b}: expected {self._channels} numbers per frame")

    def _line_of(self, offset: int) -> int:
        """The number (from 1) of the file's line that starts at byte ``offset`` (counted only for an error)."""
        count, pos = 1, 0
        with open(self.path, "rb") as f:
            while pos < offset:
                chunk = f.read(min(_SCAN, offset - pos))
                if not chunk:
                    break
                count += chunk.count(b"\n")
                pos += len(chunk)
        return count

    def __len__(self) -> int:
        return self.num_frames

    def __getitem__(self, span: slice) -> Motion:
        a, b, step = span.indices(self.num_frames)
        if step != 1 or b <= a:
            raise ValueError(f"{self.path}: expected a non-empty span of frames, got {span}")
        motion, _ = _assemble(self._hierarchy, self._parse(a, b), self._frame_time, self._frame_time_text, self._units)
        return Motion(self.skeleton, motion.lrot, motion.lpos, motion.fps)


class BvhSpanWriter:
    """Writes ``frames`` frames on ``skeleton`` with ``layout`` at ``fps`` to ``path`` span by span::

        with BvhSpanWriter(path, skeleton, layout, frames, fps) as w:
            w.append(motion_span)  # any number of frames, in order

    The file appears (by rename) only when the block ends with exactly ``frames`` frames appended; on any
    error nothing is left at ``path`` (an earlier file there is kept)."""

    def __init__(self, path: str | os.PathLike, skeleton, layout: BvhLayout, frames: int, fps: float):
        self.path, self.skeleton, self.layout, self.frames, self.fps = Path(path), skeleton, layout, frames, fps
        self.written = 0
        self._stack = contextlib.ExitStack()

    def __enter__(self):  # returns the writer
        tmp = self._stack.enter_context(atomic_output(self.path, ".tmp"))
        try:
            self._f = self._stack.enter_context(open(tmp, "w", encoding=self.layout.encoding, newline="\n"))
            import torch

            one = Motion(self.skeleton, torch.tensor([[[1.0, 0.0, 0.0, 0.0]]]).expand(1, self.skeleton.num_joints, 4),
                         self.skeleton.offsets[None], self.fps)
            lines = _header(one, self.layout)
            lines[-2] = f"Frames: {self.frames}"
            self._f.write("\n".join(lines) + "\n")
        except BaseException:
            self._stack.__exit__(*__import__("sys").exc_info())
            raise
        return self

    def append(self, motion: Motion) -> None:
        """Append ``motion``'s frames (on the writer's skeleton)."""
        if motion.skeleton.names != self.skeleton.names:
            raise ValueError("BvhSpanWriter: expected a motion on the writer's skeleton")
        if self.written + motion.num_frames > self.frames:
            raise ValueError(f"{self.path}: expected {self.frames} frames, got more")
        self._f.write("\n".join(_rows(motion, self.layout, 0, motion.num_frames)) + "\n")
        self.written += motion.num_frames

    def __exit__(self, kind, value, tb) -> bool:
        if kind is None and self.written != self.frames:
            try:
                raise ValueError(f"{self.path}: expected {self.frames} frames, wrote {self.written}; nothing written")
            except ValueError:
                import sys

                self._stack.__exit__(*sys.exc_info())
                raise
        return bool(self._stack.__exit__(kind, value, tb))
