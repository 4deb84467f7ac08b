"""BVH reading and writing. Units and Euler orders are converted here and nowhere else.

Reading gives a :class:`~motioncore.motion.Motion` in metres and quaternions plus a
:class:`BvhLayout` that remembers the file's channels and units, so that writing with the
same layout reproduces the file's structure.
"""
from __future__ import annotations

import math
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from motioncore import quat
from motioncore.files import publish
from motioncore.motion import Motion
from motioncore.skeleton import Skeleton

_CHANNELS = {f"{a}{k}" for a in "XYZ" for k in ("position", "rotation")}
MAX_JOINTS = 1024
FRAME_TIME_RANGE = (1e-4, 1.0)  # seconds: 10 kHz to 1 frame per second
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


def _motion_block(path: str, text: str, n_channels: int) -> tuple[np.ndarray, float, int, str]:
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
    rows = [ln for ln in lines[k + 1:] if ln.strip()]
    if len(rows) != n_frames:
        raise BvhError(f"{path}:{base + k + 1 + len(rows)}: declared {n_frames} frames, found {len(rows)}")
    try:
        data = np.array(" ".join(rows).split(), dtype=np.float64)
    except ValueError:
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
    r = _Reader(path, text)
    names, parents, offsets, channels, end_sites = _parse_hierarchy(r)
    n_ch = sum(len(c) for c in channels)
    data, frame_time, n_frames, frame_time_text = _motion_block(path, text, n_ch)
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
    lpos = np.broadcast_to(off * scale, (n_frames, j, 3)).copy()
    euler = np.zeros((n_frames, j, 3))
    orders = []
    col = 0
    for ji, chans in enumerate(channels):
        rot_axes = "".join(c[0] for c in chans if c.endswith("rotation"))
        for c in chans:
            if c.endswith("position"):
                lpos[:, ji, "XYZ".index(c[0])] = data[:, col] * scale
            else:
                euler[:, ji, rot_axes.index(c[0])] = np.deg2rad(data[:, col])
            col += 1
        # a joint with fewer than 3 rotation channels: fill the order with the missing axes (angle 0)
        orders.append(rot_axes + "".join(a for a in "XYZ" if a not in rot_axes))
    euler_t = torch.from_numpy(euler)
    lrot = torch.empty(n_frames, j, 4, dtype=torch.float64)
    for order in set(orders):
        sel = [i for i, o in enumerate(orders) if o == order]
        lrot[:, sel] = quat.from_euler(euler_t[:, sel], order)
    skeleton = Skeleton(
        tuple(names),
        tuple(parents),
        torch.tensor(off * scale, dtype=torch.float32),
        {k: torch.tensor(v, dtype=torch.float32) * scale for k, v in end_sites.items()},
    )
    fps = 1.0 / frame_time
    if abs(fps - round(fps)) < 1e-4 * fps:  # "0.0333333" means 30 fps
        fps = float(round(fps))
    motion = Motion(skeleton, lrot.float(), torch.from_numpy(lpos).float(), fps)
    return motion, BvhLayout(tuple(channels), scale, frame_time_text)


def read_bvh(path: str | os.PathLike, units: str | float = "auto") -> tuple[Motion, BvhLayout]:
    """Read a BVH file; raises :class:`BvhError` naming the file and line on malformed input."""
    path = os.fspath(path)
    try:
        with open(path, "r", encoding="utf-8", errors="replace", newline=None) as f:
            text = f.read()
    except OSError as e:
        raise BvhError(f"{path}: cannot read: {e.strerror or e}") from None
    if not text.strip():
        raise BvhError(f"{path}:1: empty file")
    return parse_bvh(text, path, units)


def _depth_first(children: dict[int, list[int]]) -> list[int]:
    order, stack = [], [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(children[j]))
    return order


def format_bvh(motion: Motion, layout: BvhLayout | None = None) -> str:
    """BVH text for ``motion`` with the channels and units of ``layout`` (default: ZXY, metres)."""
    sk = motion.skeleton
    layout = layout or BvhLayout.default(sk)
    if len(layout.channels) != sk.num_joints:
        raise ValueError(f"format_bvh: expected a layout for {sk.num_joints} joints, got {len(layout.channels)}")
    inv_scale = 1.0 / layout.scale
    out = ["HIERARCHY"]
    children = {i: sk.children(i) for i in range(sk.num_joints)}

    def emit(i: int, depth: int) -> None:
        pad = "  " * depth
        kw = "ROOT" if i == 0 else "JOINT"
        o = sk.offsets[i].double() * inv_scale
        out.append(f"{pad}{kw} {sk.names[i]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}  OFFSET {o[0]:.6f} {o[1]:.6f} {o[2]:.6f}")
        out.append(f"{pad}  CHANNELS {len(layout.channels[i])} {' '.join(layout.channels[i])}".rstrip())
        for c in children[i]:
            emit(c, depth + 1)
        if not children[i] or i in sk.end_sites:
            e = sk.end_sites.get(i, torch.zeros(3)).double() * inv_scale
            out.extend([f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET {e[0]:.6f} {e[1]:.6f} {e[2]:.6f}", f"{pad}  }}"])
        out.append(f"{pad}}}")

    emit(0, 0)
    cols = []
    lrot = motion.lrot.double()
    for i in _depth_first(children):  # the columns follow the hierarchy as written
        chans = layout.channels[i]
        rot_axes = "".join(c[0] for c in chans if c.endswith("rotation"))
        order = rot_axes + "".join(a for a in "XYZ" if a not in rot_axes)
        euler = torch.rad2deg(quat.to_euler(lrot[:, i], order)) if rot_axes else None
        for c in chans:
            if c.endswith("position"):
                cols.append(motion.lpos[:, i, "XYZ".index(c[0])].double() * inv_scale)
            else:
                cols.append(euler[:, order.index(c[0])])
    frames = torch.stack(cols, dim=1).numpy() if cols else np.zeros((motion.num_frames, 0))
    frame_time = f"{1.0 / motion.fps:.8f}"
    if layout.frame_time is not None and abs(float(layout.frame_time) * motion.fps - 1.0) < 1e-4:
        frame_time = layout.frame_time
    out += ["MOTION", f"Frames: {motion.num_frames}", f"Frame Time: {frame_time}"]
    out += [" ".join(f"{v:.6f}" for v in row) for row in frames]
    return "\n".join(out) + "\n"


def write_bvh(path: str | os.PathLike, motion: Motion, layout: BvhLayout | None = None) -> None:
    """Write atomically (temp file + rename), so a failure never leaves a half-written file."""
    text = format_bvh(motion, layout)
    atomic_write_text(Path(path), text)


def atomic_write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        publish(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
