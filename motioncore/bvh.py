"""BVH reading and writing. Units and Euler orders are converted here and nowhere else.

Reading gives a :class:`~motioncore.motion.Motion` in metres and quaternions plus a
:class:`BvhLayout` that remembers the file's channels and units, so that writing with the
same layout reproduces the file's structure.
"""
from __future__ import annotations

import dataclasses
import math
import os
import re
import warnings
from dataclasses import dataclass

import numpy as np
import torch

from motioncore import quat
from motioncore.files import atomic_output
from motioncore.motion import Motion
from motioncore.skeleton import Skeleton

_CHANNELS = {f"{a}{k}" for a in "XYZ" for k in ("position", "rotation")}
MAX_JOINTS = 1024
FRAME_TIME_RANGE = (1e-4, 1.0)  # seconds: 10 kHz to 1 frame per second
MAX_MAGNITUDE = 1e7  # offsets and channel values, in file units: 10 km in millimetres, 27,000 turns in degrees
_MOTION_LINE = re.compile(r"^[ \t]*MOTION[ \t]*\r?$", re.MULTILINE | re.IGNORECASE)
_KEYWORDS = {"hierarchy": "HIERARCHY", "root": "ROOT", "joint": "JOINT", "end": "End", "site": "Site",
             "offset": "OFFSET", "channels": "CHANNELS"}  # accepted in any case, as Blender's importer does


def _split_motion(text: str) -> tuple[str, str | None]:
    """(hierarchy text, text after the MOTION line or None): MOTION counts only as a line of its own."""
    m = _MOTION_LINE.search(text)
    return (text, None) if m is None else (text[:m.start()], text[m.end():])


class BvhError(ValueError):
    """A malformed BVH file; the message names the file and the line."""


@dataclass(frozen=True)
class BvhLayout:
    """Per-joint channel names as in the file, and metres per file unit."""

    channels: tuple[tuple[str, ...], ...]
    scale: float = 1.0
    frame_time: str | None = None  # "Frame Time:" as the file wrote it; kept on writing at the same frame rate
    encoding: str = "utf-8"  # "latin-1" for a file that is not UTF-8: its joint names are written back byte for byte
    # the OFFSETs as the file has them (file units, float64): written back as they were where the skeleton still
    # has them (the float32 skeleton alone would write 10.000000 as 9.999999)
    offsets: tuple[tuple[float, float, float], ...] | None = None
    end_sites: tuple[tuple[int, tuple[float, float, float]], ...] | None = None

    @staticmethod
    def default(skeleton: Skeleton, order: str = "ZXY", scale: float = 1.0) -> BvhLayout:
        """Root with position + rotation channels, other joints rotation only."""
        rot = tuple(f"{a}rotation" for a in order)
        pos = ("Xposition", "Yposition", "Zposition")
        return BvhLayout(tuple((pos + rot) if i == 0 else rot for i in range(skeleton.num_joints)), scale)


def _tokens(text: str):
    """``(line number, token with keywords in their usual spelling, token as written)``."""
    for lineno, line in enumerate(text.splitlines(), 1):
        for tok in line.split():
            yield lineno, _KEYWORDS.get(tok.lower(), tok), tok


class _Reader:
    def __init__(self, path: str, text: str):
        self.path = path
        self.toks = list(_tokens(_split_motion(text)[0]))
        self.i = 0

    def error(self, msg: str, lineno: int | None = None) -> BvhError:
        if lineno is None:
            lineno = self.toks[min(self.i, len(self.toks) - 1)][0] if self.toks else 1
        return BvhError(f"{self.path}:{lineno}: {msg}")

    def next(self, what: str) -> tuple[int, str]:
        if self.i >= len(self.toks):
            raise self.error(f"unexpected end of hierarchy, expected {what}")
        self.i += 1
        return self.toks[self.i - 1][:2]

    def name(self) -> tuple[int, str]:
        """A joint name: the rest of its line as written (3ds Max names have spaces, UE has a joint
        called ``root``), up to a ``{`` on the same line."""
        if self.i >= len(self.toks):
            raise self.error("unexpected end of hierarchy, expected a joint name")
        lineno, parts = self.toks[self.i][0], []
        while self.i < len(self.toks) and self.toks[self.i][0] == lineno and self.toks[self.i][2] != "{":
            parts.append(self.toks[self.i][2])
            self.i += 1
        if not parts:
            raise self.error("expected a joint name", lineno)
        return lineno, " ".join(parts)

    def expect(self, word: str) -> int:
        lineno, tok = self.next(word)
        if tok != word:
            raise self.error(f"expected {word!r}, got {tok!r}", lineno)
        return lineno

    def number(self, what: str) -> float:
        lineno, tok = self.next(what)
        try:
            v = float(tok)
        except ValueError:
            raise self.error(f"expected a number for {what}, got {tok!r}", lineno) from None
        if not math.isfinite(v):
            raise self.error(f"expected a finite number for {what}, got {tok!r}", lineno)
        if abs(v) > MAX_MAGNITUDE:
            raise self.error(f"expected a number of magnitude at most {MAX_MAGNITUDE:g} for {what}, got {tok[:40]!r}",
                             lineno)
        return v


def _parse_hierarchy(r: _Reader):
    names, parents, offsets, channels, end_sites = [], [], [], [], {}
    r.expect("HIERARCHY")
    lineno, tok = r.next("ROOT")
    if tok != "ROOT":
        raise r.error(f"expected 'ROOT', got {tok!r}", lineno)
    stack: list[int] = []  # open joints; -2 marks an open End Site
    kind = "ROOT"
    while True:
        if kind in ("ROOT", "JOINT"):
            lineno, name = r.name()
            if name in names:
                raise r.error(f"duplicate joint name {name!r}", lineno)
            if len(names) >= MAX_JOINTS:
                raise r.error(f"more than {MAX_JOINTS} joints", lineno)
            names.append(name)
            parents.append(stack[-1] if stack else -1)
            r.expect("{")
            r.expect("OFFSET")
            offsets.append([r.number("OFFSET x"), r.number("OFFSET y"), r.number("OFFSET z")])
            r.expect("CHANNELS")
            n = r.number("the channel count")
            if n != int(n) or not 0 <= n <= 6:
                raise r.error(f"expected 0 to 6 channels, got {n:g}")
            chans = []
            for _ in range(int(n)):
                lineno, c = r.next("a channel name")
                c = c[:1].upper() + c[1:].lower()  # xROTATION, Xrotation, XRotation: one spelling
                if c not in _CHANNELS or c in chans:
                    raise r.error(f"expected a channel name like Xrotation, got {c!r}", lineno)
                chans.append(c)
            channels.append(tuple(chans))
            stack.append(len(names) - 1)
        elif kind == "End":
            r.expect("Site")
            r.expect("{")
            r.expect("OFFSET")
            off = [r.number("OFFSET x"), r.number("OFFSET y"), r.number("OFFSET z")]
            r.expect("}")
            if not stack:
                raise r.error("End Site outside a joint")
            end_sites[stack[-1]] = off
        elif kind == "}":
            stack.pop()
            if not stack:
                break
        # what comes next inside the current joint
        lineno, kind = r.next("JOINT, End Site or '}'")
        if kind not in ("JOINT", "End", "}"):
            raise r.error(f"expected JOINT, End Site or '}}', got {kind!r}", lineno)
    if r.i < len(r.toks):
        lineno, tok = r.next("MOTION")
        if tok == "ROOT":
            raise r.error("a second ROOT: this file holds more than one skeleton; save one figure per file", lineno)
        raise r.error(f"expected MOTION after the hierarchy, got {tok!r}", lineno)
    return names, parents, offsets, channels, end_sites


def _numbers(text: str) -> np.ndarray | None:
    """All whitespace-separated numbers of ``text`` (parsed in C: a 2-hour take is millions), None if any is not one."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # numpy warns, and stops, at the first non-number
        try:
            return np.fromstring(text, dtype=np.float64, sep=" ")
        except (ValueError, DeprecationWarning):
            return None


def _motion_block(path: str, text: str, n_channels: int, declared_only: bool = False) -> tuple[np.ndarray | None, float, int, str]:
    head, rest = _split_motion(text)
    if rest is None:
        raise BvhError(f"{path}:{text.count(chr(10)) + 1}: missing MOTION section")
    lines = rest.splitlines()  # index 0: what follows MOTION on its own line (nothing)
    base = head.count("\n") + 1  # line number of the MOTION line

    def field(k: int, label: str, pattern: str) -> str:
        while k < len(lines) and not lines[k].strip():
            k += 1
        m = re.match(pattern, lines[k], re.IGNORECASE) if k < len(lines) else None
        if m is None:
            raise BvhError(f"{path}:{base + k}: expected '{label}'")
        return m.group(1).strip(), k

    frames_s, k = field(1, "Frames:", r"\s*Frames\s*:(.*)$")
    time_s, k = field(k + 1, "Frame Time:", r"\s*Frame\s+Time\s*:(.*)$")
    try:
        n_frames = int(frames_s)
        frame_time = float(time_s)
    except ValueError:
        raise BvhError(f"{path}:{base + k}: expected a frame count and a frame time, got {frames_s!r} and {time_s!r}") from None
    if n_frames < 1:
        raise BvhError(f"{path}:{base + k - 1}: expected at least one frame, got {n_frames}")
    if not (math.isfinite(frame_time) and FRAME_TIME_RANGE[0] <= frame_time <= FRAME_TIME_RANGE[1]):
        raise BvhError(f"{path}:{base + k}: expected a frame time from {FRAME_TIME_RANGE[0]:g} to "
                       f"{FRAME_TIME_RANGE[1]:g} s, got {time_s}")
    if declared_only:  # the caller reads the numbers itself
        return None, frame_time, n_frames, time_s
    rows = [ln for ln in lines[k + 1:] if ln.strip()]
    if len(rows) != n_frames:
        raise BvhError(f"{path}:{base + k + 1 + len(rows)}: declared {n_frames} frames, found {len(rows)}")
    data = _numbers("\n".join(rows))
    if data is None:
        for off, ln in enumerate(lines[k + 1:]):
            try:
                np.array(ln.split(), dtype=np.float64)
            except ValueError:
                raise BvhError(f"{path}:{base + k + 1 + off}: expected numbers in the frame data") from None
        raise BvhError(f"{path}: bad frame data") from None
    if data.size != n_frames * n_channels:
        for off, ln in enumerate(x for x in lines[k + 1:]):
            if ln.strip() and len(ln.split()) != n_channels:
                raise BvhError(f"{path}:{base + k + 1 + off}: expected {n_channels} values per frame, got {len(ln.split())}")
    if not np.isfinite(data).all():
        raise BvhError(f"{path}: frame data holds NaN or infinite values")
    if data.size and np.abs(data).max() > MAX_MAGNITUDE:
        raise BvhError(f"{path}: frame data holds values of magnitude above {MAX_MAGNITUDE:g} "
                       f"(up to {np.abs(data).max():.3g})")
    return data.reshape(n_frames, n_channels), frame_time, n_frames, time_s


def _guess_scale(offsets: np.ndarray, parents: list[int]) -> float:
    """Metres per file unit from the rest skeleton's size: metres, centimetres, or normalised."""
    pos = np.zeros_like(offsets)
    for i in range(1, len(parents)):
        pos[i] = pos[parents[i]] + offsets[i]
    extent = float(np.linalg.norm(pos.max(0) - pos.min(0))) if len(pos) > 1 else 0.0
    if extent <= 0:
        return 1.0
    if extent < 5.0:
        return 1.0
    if 50.0 <= extent <= 600.0:
        return 0.01
    return 1.8 / extent  # unknown units: scale to a human-sized figure


def parse_bvh(text: str, path: str = "<string>", units: str | float = "auto") -> tuple[Motion, BvhLayout]:
    """Parse BVH text. ``units``: "auto", "m", "cm", "mm" or metres per file unit. Accepted as the usual
    importers accept them: a UTF-8 byte-order mark, keywords in any case, any spacing in "Frame Time:"."""
    text = text.removeprefix("\ufeff")
    hierarchy = _parse_hierarchy(_Reader(path, text))
    n_ch = sum(len(c) for c in hierarchy[3])
    data, frame_time, _, frame_time_text = _motion_block(path, text, n_ch)
    return _assemble(hierarchy, data, frame_time, frame_time_text, units)


_CHUNK = 5_000  # frames converted or written at a time: bounds the temporaries of a long take


def _assemble(hierarchy, data: np.ndarray, frame_time: float, frame_time_text: str,
              units: str | float) -> tuple[Motion, BvhLayout]:
    """The motion and layout from the parsed hierarchy and the ``(frames, channels)`` numbers."""
    names, parents, offsets, channels, end_sites = hierarchy
    n_frames = data.shape[0]
    off = np.asarray(offsets, dtype=np.float64)
    if units == "auto":
        scale = _guess_scale(off, parents)
    elif isinstance(units, str):
        table = {"m": 1.0, "cm": 0.01, "mm": 0.001}
        if units not in table:
            raise ValueError(f"units: expected 'auto', 'm', 'cm', 'mm' or a number, got {units!r}")
        scale = table[units]
    else:
        scale = float(units)

    j = len(names)
    lpos = torch.from_numpy(off * scale).float().expand(n_frames, j, 3).clone()
    lrot = torch.empty(n_frames, j, 4)
    cols, orders = [], []  # per joint: the data column of each of X, Y, Z rotation (-1: none), Euler order
    col = 0
    for ji, chans in enumerate(channels):
        rot_axes = "".join(c[0] for c in chans if c.endswith("rotation"))
        where = [-1, -1, -1]
        for c in chans:
            if c.endswith("position"):
                lpos[:, ji, "XYZ".index(c[0])] = torch.from_numpy(data[:, col] * scale)
            else:
                where[rot_axes.index(c[0])] = col
            col += 1
        cols.append(where)
        # a joint with fewer than 3 rotation channels: fill the order with the missing axes (angle 0)
        orders.append(rot_axes + "".join(a for a in "XYZ" if a not in rot_axes))
    for order in set(orders):
        sel = [i for i, o in enumerate(orders) if o == order]
        idx = np.asarray([cols[i] for i in sel])  # (sel, 3); -1: no such channel, angle 0
        for a in range(0, n_frames, _CHUNK):
            part = data[a:a + _CHUNK]
            euler = np.where(idx >= 0, part[:, np.maximum(idx, 0)], 0.0)  # (chunk, sel, 3)
            lrot[a:a + _CHUNK, sel] = quat.from_euler(torch.from_numpy(np.deg2rad(euler)), order).float()
    skeleton = Skeleton(
        tuple(names),
        tuple(parents),
        torch.tensor(off * scale, dtype=torch.float32),
        {k: torch.tensor(np.asarray(v, dtype=np.float64) * scale, dtype=torch.float32) for k, v in end_sites.items()},
    )
    fps = 1.0 / frame_time
    if abs(fps - round(fps)) < 1e-4 * fps:  # "0.0333333" means 30 fps
        fps = float(round(fps))
    layout = BvhLayout(tuple(channels), scale, frame_time_text,
                       offsets=tuple(tuple(float(x) for x in o) for o in off.tolist()),
                       end_sites=tuple(sorted((k, tuple(float(x) for x in v)) for k, v in end_sites.items())))
    return Motion(skeleton, lrot, lpos, fps), layout


STREAM_BYTES = 16 * 1024 * 1024  # larger files: the frame numbers are read straight from the file


def read_bvh(path: str | os.PathLike, units: str | float = "auto") -> tuple[Motion, BvhLayout]:
    """Read a BVH file; raises :class:`BvhError` naming the file and line on malformed input."""
    path = os.fspath(path)
    if os.path.isdir(path):
        raise BvhError(f"{path}: is a folder, not a BVH file")
    try:
        if os.path.getsize(path) > STREAM_BYTES:
            fast = _read_large(path, units)
            if fast is not None:
                return fast
        with open(path, "rb") as f:
            text, encoding = _decode(f.read())
    except OSError as e:
        raise BvhError(f"{path}: cannot read: {e.strerror or e}") from None
    if not text.strip():
        raise BvhError(f"{path}:1: empty file")
    motion, layout = parse_bvh(text.replace("\r\n", "\n").replace("\r", "\n"), path, units)
    return motion, dataclasses.replace(layout, encoding=encoding)


def _decode(raw: bytes) -> tuple[str, str]:
    """``(text, encoding)``: UTF-8, else Latin-1 (every byte a character), so that a joint name in a legacy
    encoding is neither replaced by U+FFFD nor changed when written back with the same encoding."""
    try:
        return raw.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        return raw.decode("latin-1"), "latin-1"


def _read_large(path: str, units: str | float) -> tuple[Motion, BvhLayout] | None:
    """A long take without holding its text: the header as text, the numbers parsed from the file by numpy.
    None when anything is off (the text path then says what, with the line)."""
    head, tail = [], []
    with open(path, "rb") as f:
        size = 0
        for raw in f:
            size += len(raw)
            if size > STREAM_BYTES:
                return None
            line = raw.decode("latin-1")  # the header is decoded again below, as read_bvh does
            (tail if tail or _MOTION_LINE.match(line.rstrip("\n")) else head).append(line)
            if len([t for t in tail if t.strip()]) == 3:  # MOTION, Frames:, Frame Time:
                break
        else:
            return None
        text, encoding = _decode("".join(head + tail).encode("latin-1"))
        try:
            hierarchy = _parse_hierarchy(_Reader(path, text.removeprefix("\ufeff")))
            n_ch = sum(len(c) for c in hierarchy[3])
            _, frame_time, n_frames, frame_time_text = _motion_block(path, text, n_ch, declared_only=True)
        except BvhError:
            return None
        data = np.empty((n_frames, n_ch), dtype=np.float32)  # float32 like the motion: half the memory
        row = 0
        while True:
            lines = [ln for ln in f.readlines(1 << 24) if ln.strip()]  # ~16 MB of text at a time
            if not lines:
                break
            part = _numbers(b"".join(lines).decode("ascii", errors="replace"))
            if part is None or part.size != len(lines) * n_ch or row + len(lines) > n_frames:
                return None
            data[row:row + len(lines)] = part.reshape(len(lines), n_ch)
            row += len(lines)
    if row != n_frames or not np.isfinite(data).all() or (data.size and np.abs(data).max() > MAX_MAGNITUDE):
        return None
    motion, layout = _assemble(hierarchy, data, frame_time, frame_time_text, units)
    return motion, dataclasses.replace(layout, encoding=encoding)


def _depth_first(children: dict[int, list[int]]) -> list[int]:
    order, stack = [], [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(children[j]))
    return order


def _header(motion: Motion, layout: BvhLayout) -> list[str]:
    sk = motion.skeleton
    if len(layout.channels) != sk.num_joints:
        raise ValueError(f"format_bvh: expected a layout for {sk.num_joints} joints, got {len(layout.channels)}")
    inv_scale = 1.0 / layout.scale
    out = ["HIERARCHY"]
    children = {i: sk.children(i) for i in range(sk.num_joints)}
    file_offsets = layout.offsets if layout.offsets is not None and len(layout.offsets) == sk.num_joints else None
    file_ends = dict(layout.end_sites or ())

    def as_written(metres: torch.Tensor, written) -> tuple[float, float, float]:
        """An offset in file units: the file's own where the skeleton still has it (to float32's precision)."""
        if written is not None and torch.allclose(metres.double(), torch.tensor(written, dtype=torch.float64) *
                                                  layout.scale, rtol=1e-6, atol=1e-9):
            return written
        return tuple(float(x) for x in metres.double() * inv_scale)

    def emit(i: int, depth: int) -> None:
        pad = "  " * depth
        kw = "ROOT" if i == 0 else "JOINT"
        o = as_written(sk.offsets[i], file_offsets[i] if file_offsets is not None else None)
        out.append(f"{pad}{kw} {sk.names[i]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}  OFFSET {o[0]:.6f} {o[1]:.6f} {o[2]:.6f}")
        out.append(f"{pad}  CHANNELS {len(layout.channels[i])} {' '.join(layout.channels[i])}".rstrip())
        for c in children[i]:
            emit(c, depth + 1)
        if not children[i] or i in sk.end_sites:
            e = as_written(sk.end_sites[i], file_ends.get(i)) if i in sk.end_sites else (0.0, 0.0, 0.0)
            out.extend([f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {e[0]:.6f} {e[1]:.6f} {e[2]:.6f}", f"{pad}  }}"])
        out.append(f"{pad}}}")

    emit(0, 0)
    frame_time = f"{1.0 / motion.fps:.8f}"
    if layout.frame_time is not None and abs(float(layout.frame_time) * motion.fps - 1.0) < 1e-4:
        frame_time = layout.frame_time
    return out + ["MOTION", f"Frames: {motion.num_frames}", f"Frame Time: {frame_time}"]


def _rows(motion: Motion, layout: BvhLayout, start: int, stop: int) -> list[str]:
    """The frame lines ``start:stop``, columns in the order the hierarchy lists the joints."""
    sk = motion.skeleton
    if not torch.isfinite(motion.lrot[start:stop]).all() or not torch.isfinite(motion.lpos[start:stop]).all():
        raise ValueError("format_bvh: the motion holds NaN or infinite values; nothing written")
    inv_scale = 1.0 / layout.scale
    children = {i: sk.children(i) for i in range(sk.num_joints)}
    cols = []
    lrot = motion.lrot[start:stop].double()
    for i in _depth_first(children):
        chans = layout.channels[i]
        rot_axes = "".join(c[0] for c in chans if c.endswith("rotation"))
        order = rot_axes + "".join(a for a in "XYZ" if a not in rot_axes)
        euler = torch.rad2deg(quat.to_euler(lrot[:, i], order)) if rot_axes else None
        for c in chans:
            if c.endswith("position"):
                cols.append(motion.lpos[start:stop, i, "XYZ".index(c[0])].double() * inv_scale)
            else:
                cols.append(euler[:, order.index(c[0])])
    frames = torch.stack(cols, dim=1).numpy() if cols else np.zeros((stop - start, 0))
    return [" ".join(f"{v:.6f}" for v in row) for row in frames]


def format_bvh(motion: Motion, layout: BvhLayout | None = None) -> str:
    """BVH text for ``motion`` with the channels and units of ``layout`` (default: ZXY, metres)."""
    layout = layout or BvhLayout.default(motion.skeleton)
    return "\n".join(_header(motion, layout) + _rows(motion, layout, 0, motion.num_frames)) + "\n"


def write_bvh(path: str | os.PathLike, motion: Motion, layout: BvhLayout | None = None) -> None:
    """Write atomically (temp file + rename), so a failure never leaves a half-written file; long takes
    are written a chunk of frames at a time."""
    layout = layout or BvhLayout.default(motion.skeleton)
    with atomic_output(path, ".tmp") as tmp, open(tmp, "w", encoding=layout.encoding, newline="\n") as f:
        f.write("\n".join(_header(motion, layout)) + "\n")
        f.writelines("\n".join(_rows(motion, layout, a, min(a + _CHUNK, motion.num_frames))) + "\n" for a in range(0, motion.num_frames, _CHUNK))
