"""``apply`` on a long BVH take a span at a time, with memory that does not grow with the take (issue 25).

A take longer than :data:`LONG_TAKE_SECONDS` is read from its file a span of frames at a time
(:class:`motioncore.bvh_stream.BvhFrames`), resampled and retargeted to the canonical skeleton, styled by apply's one
path (:func:`transfer.spans.stylize_spans`: the whole clip's diffusion windows, then each span guarded, decoded and
its feet cleaned, seeing :data:`MARGIN` frames either side), carried back to the file's skeleton and appended to the
output (:class:`motioncore.bvh_stream.BvhSpanWriter`: a temporary file renamed at the end). Three things are the whole
take's and gathered by a first pass over it: the floor (:func:`place_on_floor`'s shift), each foot joint's lowest
height (the contact channels) and the peak joint acceleration (apply's spike limit, :func:`transfer.spans.clean_feet`). The result equals the whole-clip path's (the tests: within 0.05 cm, guards off)
except where a foot contact lasts longer than the margin across a span's end, except that ``--feet auto`` keeps or
leaves each span's foot cleanup as that span's sliding says, and except for the guards that read time means (the posture match, the arms' hold on a clip done in place, the content keeper, the stray-limb guard):
each span's are its own (:data:`SPAN_FRAMES`, 5 minutes), not the whole take's.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import torch

from motioncore.bvh_stream import BvhFrames, BvhSpanWriter
from motioncore.feet import peak_acceleration
from motioncore.ik_fit import conform_rolls, off_roll_convention
from motioncore.motion import Motion, resample_span, resampled_frames
from motioncore.retarget import (
    carry_edit,
    floor_shift,
    lowest_feet,
    make_rig,
    to_canonical,
)
from motioncore.skeleton import CANONICAL
from video2style.clip_limits import check_frames, check_length
from video2style.result import ApplyResult

LONG_TAKE_SECONDS = 300.0  # BVH takes longer than this are applied a span at a time
SPAN_FRAMES = 6_000  # canonical frames (5 minutes at 20 fps) converted, decoded and written at a time
MARGIN = 60  # canonical frames of context either side of a span for decoding, foot cleanup and the write-back


def is_long_take(path: Path) -> bool:
    """True for a BVH file ``path`` longer than :data:`LONG_TAKE_SECONDS` (its header read; frames counted)."""
    if not Path(path).is_file():
        return False
    try:
        frames, frame_time = BvhFrames.declared(path)
    except (ValueError, OSError):
        return False  # the whole-clip reader says what is wrong with it
    return frames * frame_time > LONG_TAKE_SECONDS


class _Take:
    """A BVH take's canonical frames, computed a span at a time from its file."""

    def __init__(self, frames: BvhFrames, rig, n: int):
        self.frames, self.rig, self.n = frames, rig, n
        self.shift = None  # place_on_floor's, once known
        self.conform = None  # whether the take's bone rolls are solved again (conform_rolls), decided on its first span

    def source_range(self, a: int, b: int) -> tuple[int, int]:
        """The file frames canonical frames ``a..b-1`` are interpolated from."""
        r = self.frames.fps / CANONICAL.fps
        lo = max(0, min(self.frames.num_frames - 1, math.floor(a * r) - 1))
        hi = min(self.frames.num_frames, math.floor((b - 1) * r) + 3)
        return lo, hi

    def canonical(self, a: int, b: int) -> Motion:
        s0, s1 = self.source_range(a, b)
        m = resample_span(self.frames[s0:s1], CANONICAL.fps, a, b, first=s0, total=self.frames.num_frames)
        canon = to_canonical(m, self.rig)
        if self.conform is None:
            self.conform = off_roll_convention(canon)
        canon = conform_rolls(canon, force=self.conform)
        if self.shift is not None:
            lpos = canon.lpos.clone()
            lpos[:, 0, 1] -= self.shift
            canon = Motion(canon.skeleton, canon.lrot, lpos, canon.fps)
        return canon

    def source_frames(self, c: int, d: int) -> tuple[int, int]:
        """The file frames whose times fall in canonical frames ``[c, d)`` (the last span: to the end)."""
        per = CANONICAL.fps / self.frames.fps  # canonical frames per file frame

        def first_at(x: int) -> int:
            k = max(0, math.ceil(x / per) - 1)
            while k * per < x:
                k += 1
            return min(k, self.frames.num_frames)

        return first_at(c), (self.frames.num_frames if d >= self.n else first_at(d))


@dataclass
class Shown:
    """A long take's first frames, for its preview: the canonical ``content`` and ``result``, the result as
    ``written`` on the file's skeleton, and the take's ``rig`` and BVH ``layout``."""

    content: Motion
    result: Motion
    written: Motion
    rig: object
    layout: object


def apply_long_bvh(style, path: Path, out_dir: Path, request, joint_map: dict | None = None,
                   span: int | None = None, margin: int | None = None) -> tuple[ApplyResult, Shown | None]:
    """:meth:`video2style.loaded_style.LoadedStyle.apply` for a long BVH take (``style``: the
    :class:`~video2style.loaded_style.LoadedStyle`; ``request``: its :class:`~video2style.options.ApplyOptions`),
    a span of ``span`` canonical frames at a time (default :data:`SPAN_FRAMES`, :data:`MARGIN` either side; see the
    module's docstring); writes ``out_dir/<name>.bvh``. Returns the result (``skating_*`` pooled over the spans,
    each span measured on its own; ``still_share``, ``arm_motion_share`` and ``content_share`` the smallest of any
    span's; ``streamed``, the number of spans; no preview yet) and, with ``request.preview``, its first
    :data:`video2style.preview.MAX_PREVIEW_SECONDS` (:class:`Shown`; else None) for apply's preview.
    ``request.feet``: auto, lock or off (:func:`transfer.spans.clean_feet`, each span on its own; ``feet_cleaned``:
    every span's feet were cleaned, ``feet_cleaned_spans``: how many were)."""
    t0 = time.time()
    span = SPAN_FRAMES if span is None else span  # the module's, read at the call (tests make them small)
    margin = MARGIN if margin is None else margin
    path, out_dir = Path(path), Path(out_dir)
    frames = BvhFrames(path)
    check_length(path, frames.num_frames, frames.fps)
    n = resampled_frames(frames.num_frames, frames.fps, CANONICAL.fps)
    check_frames(path, n)
    span = max(int(span), 2 * margin + 2)
    first = frames[0:min(frames.num_frames, 2_000)]
    rig = make_rig(frames.skeleton, first, joint_map, source=str(path))
    take = _Take(frames, rig, n)

    # pass 1: the floor, the feet's lowest heights and the peak joint acceleration, a span at a time
    lowest, feet_min, content_acc = torch.empty(n), None, 0.0
    for a in range(0, n, span):
        part = take.canonical(max(0, a - 1), min(n, a + span + 1))  # a frame either side: the accelerations there
        gpos = part.global_positions()
        inner = slice(a - max(0, a - 1), a - max(0, a - 1) + min(n, a + span) - a)
        lowest[a:min(n, a + span)] = lowest_feet(part.slice(inner.start, inner.stop))
        m = gpos[inner, list(CANONICAL.feet), 1].amin(0)
        feet_min = m if feet_min is None else torch.minimum(feet_min, m)
        content_acc = max(content_acc, peak_acceleration(gpos, CANONICAL.fps))
    take.shift = floor_shift(lowest)
    feet_min = feet_min - take.shift
    del lowest

    from video2style.preview import MAX_PREVIEW_SECONDS

    shown = min(n, int(MAX_PREVIEW_SECONDS * CANONICAL.fps)) if request.preview else 0
    kept = {"content": [], "result": [], "written": []}  # the previewed frames
    sums = {"skating_before": 0.0, "skating_after": 0.0, "skating_content": 0.0, "skating_low_steps": 0.0}
    decided: dict = {}
    out_path = out_dir / f"{path.stem}.bvh"
    spans = cleaned = 0
    asked = False
    per = CANONICAL.fps / frames.fps
    with BvhSpanWriter(out_path, frames.skeleton, frames.layout, frames.num_frames, frames.fps) as writer:
        for done in style.spans(take.canonical, n, request, floor=feet_min, span=span, margin=margin, report=decided,
                                content_acc=content_acc):
            c, d = done.start, done.stop
            for key, value in done.skating.items():
                if key in sums:
                    sums[key] += value * (d - c)
            cleaned += bool(done.skating.get("feet_cleaned"))
            asked = done.skating.get("feet_cleaned") is not None  # off, or --strength 0: no cleanup to report
            k0, k1 = take.source_frames(c, d)
            if k1 > k0:
                on_file = carry_edit(frames[k0:k1], done.content, done.result, rig, offset=k0 * per - done.lo)
                writer.append(on_file)
                if c < shown:
                    kept["written"].append(on_file)
            if c < shown:
                end = min(d, shown)
                kept["content"].append(done.content.slice(c - done.lo, end - done.lo))
                kept["result"].append(done.result.slice(c - done.lo, end - done.lo))
            spans += 1
    result = ApplyResult(str(path), [str(out_path)], frames=n, **{k: v / n for k, v in sums.items()}, **decided,
                         tempo=1.0, streamed=spans, feet_cleaned=(cleaned == spans) if asked else None,
                         feet_cleaned_spans=cleaned, seconds_transfer=time.time() - t0, rolls_conformed=take.conform,
                         stream_note=f"a take over {LONG_TAKE_SECONDS / 60:g} min: applied {spans} span(s) of up to "
                                     f"{span / CANONICAL.fps / 60:g} min at a time (memory does not grow with the "
                                     "take); its posture, arm hold, content keeper and stray-limb guard read each "
                                     "span on its own")
    if not request.preview:
        return result, None
    joined = {k: _joined(v) for k, v in kept.items()}
    return result, Shown(joined["content"], joined["result"], joined["written"], rig, frames.layout)


def _joined(parts: list[Motion]) -> Motion:
    return Motion(parts[0].skeleton, torch.cat([p.lrot for p in parts]), torch.cat([p.lpos for p in parts]),
                  parts[0].fps)
