"""``apply`` on a long BVH take a span at a time, with memory that does not grow with the take (issue 25).

A take longer than :data:`LONG_TAKE_SECONDS` is read from its file a span of frames at a time
(:class:`motioncore.bvh_stream.BvhFrames`), resampled and retargeted to the canonical skeleton, stylised by the
same diffusion windows as the whole clip (the same starts, the same batches, the same noise, each window's
crossfade finished across the span's end), decoded, its feet cleaned, carried back to the file's skeleton and
appended to the output (:class:`motioncore.bvh_stream.BvhSpanWriter`: a temporary file renamed at the end).
Two things are the whole take's and gathered by a first pass over it: the floor (:func:`place_on_floor`'s
shift) and each foot joint's lowest height (the contact channels). Decoding, foot cleanup and the write-back
see :data:`MARGIN` frames either side of each span; the result equals the whole-clip path's (the tests: within
0.05 cm) except where a foot contact lasts longer than the margin across a span's end, and except for the
stray-limb guard (``ApplyConfig.limb_guard``, :func:`transfer.apply.guard_stray_limbs`) and the posture match
(``ApplyConfig.posture``, :func:`transfer.posture.match_posture`), which need the whole result's time means and are
not applied to a take streamed a span at a time, nor are the arm gate (``ApplyConfig.arm_gate``,
:func:`transfer.posture.arm_gate`), the arms' hold on a clip done in place (``ApplyConfig.arm_travel``,
:func:`transfer.posture.keep_arm_motion`) or the content keeper (``ApplyConfig.content_keep``, :func:`transfer.apply.keep_content`),
applied with them after the whole clip's windows.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from pathlib import Path

import torch

from motioncore.bvh_stream import BvhFrames, BvhSpanWriter
from motioncore.cleanup import cleanup_feet
from motioncore.ik_fit import conform_rolls, off_roll_convention
from motioncore.motion import Motion, resample_span, resampled_frames
from motioncore.representation import FEATURES, encode, facing_angle
from motioncore.retarget import (
    carry_edit,
    floor_shift,
    lowest_feet,
    make_rig,
    to_canonical,
)
from motioncore.skeleton import CANONICAL
from transfer.windows import window_starts

LONG_TAKE_SECONDS = 300.0  # BVH takes longer than this are applied a span at a time
SPAN_FRAMES = 6_000  # canonical frames (5 minutes at 20 fps) converted, decoded and written at a time
MARGIN = 60  # canonical frames of context either side of a span for decoding, foot cleanup and the write-back


def is_long_take(path: Path) -> bool:
    """True for a BVH file longer than :data:`LONG_TAKE_SECONDS` (its header read; frames counted)."""
    from video2style.pipeline import BVH_SUFFIX

    if Path(path).suffix.lower() != BVH_SUFFIX or not Path(path).is_file():
        return False
    try:
        frames, frame_time = BvhFrames.declared(path)
    except (ValueError, OSError):
        return False  # the whole-clip reader says what is wrong with it
    return frames * frame_time > LONG_TAKE_SECONDS


class WindowStream:
    """The diffusion windows of a take of ``n`` frames (:func:`transfer.windows.window_starts`), run on its
    features fed in order, a span at a time: ``feed(x)`` takes the next frames ``(k, D)`` and returns the
    frames now finished (every window over them blended, as :func:`transfer.windows.crossfade` blends them).
    ``fn(batch (B, L, D))`` gives the windows' results; batches are the whole clip's (``batch`` windows from
    the first), so noise drawn in order from one generator is the same noise."""

    def __init__(self, fn: Callable[[torch.Tensor, int], Iterable[torch.Tensor]], n: int, batch: int,
                 window: int = 80, overlap: int = 20):
        self.fn, self.n, self.batch = fn, n, batch
        self.starts = window_starts(n, window, overlap)
        self.length = min(window, n)
        self.inbuf, self.in0 = None, 0  # input frames from in0 on
        self.acc, self.tot, self.out0 = None, None, 0  # blend of frames out0.. (not yet finished)
        self.i, self.prev_end = 0, 0

    def feed(self, x: torch.Tensor) -> torch.Tensor:
        self.inbuf = x if self.inbuf is None else torch.cat([self.inbuf, x])
        in_end = self.in0 + self.inbuf.shape[0]
        while self.i < len(self.starts):
            j = min(self.i + self.batch, len(self.starts))
            if self.starts[j - 1] + self.length > in_end:
                break
            starts = self.starts[self.i:j]
            part = torch.stack([self.inbuf[s - self.in0:s - self.in0 + self.length] for s in starts])
            for chunk, s in zip(self.fn(part, self.i), starts):
                self._add(chunk, s)
            self.i = j
        done = self.starts[self.i] if self.i < len(self.starts) else self.n
        if self.i < len(self.starts):  # the inputs before the next window are no longer needed
            self.inbuf, self.in0 = self.inbuf[done - self.in0:], done
        if self.acc is None or done <= self.out0:
            return x.new_zeros(0, x.shape[1])
        k = done - self.out0
        out = self.acc[:k].div_(self.tot[:k].clamp_min_(1e-6))
        self.acc, self.tot, self.out0 = self.acc[k:], self.tot[k:], done
        return out

    def _add(self, chunk: torch.Tensor, s: int) -> None:
        length = chunk.shape[0]
        end = s + length - self.out0
        if self.acc is None:
            self.acc = chunk.new_zeros(0, chunk.shape[-1])
            self.tot = chunk.new_zeros(0, 1)
        if end > self.acc.shape[0]:
            grow = end - self.acc.shape[0]
            self.acc = torch.cat([self.acc, chunk.new_zeros(grow, chunk.shape[-1])])
            self.tot = torch.cat([self.tot, chunk.new_zeros(grow, 1)])
        w = torch.ones(length, device=chunk.device)
        if s > 0:  # ramp in over the overlap with the previous window (as crossfade)
            ramp = max(1, self.prev_end - s)
            w[:ramp] = torch.linspace(0, 1, ramp + 2, device=chunk.device)[1:-1]
        a = s - self.out0
        self.acc[a:a + length] += chunk * w[:, None]
        self.tot[a:a + length] += w[:, None]
        self.prev_end = max(self.prev_end, s + length)


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


def apply_long_bvh(style, model, path: Path, out_dir: Path, strength: float = 0.5, seed: int = 0,
                   neutralize: str = "auto", joint_map: dict | None = None, preview: bool = True,
                   span: int | None = None, margin: int | None = None) -> dict:
    """:func:`video2style.pipeline.apply_file` for a long BVH take, a span of ``span`` canonical frames at a
    time (default :data:`SPAN_FRAMES`, :data:`MARGIN` either side; see the module's docstring); writes ``out_dir/<name>.bvh`` and, with ``preview``, the preview and player
    of its first :data:`video2style.preview.MAX_PREVIEW_SECONDS`. Returns what apply_file returns (``skating_*``
    pooled over the spans, each span measured on its own) and ``streamed``, the number of spans."""
    import transfer.apply as apply_mod
    from motioncore.skating import motion_skating
    from transfer.bundle import load_models
    from transfer.device import model_device
    from transfer.edit import neutralize as neutralize_windows
    from transfer.edit import stylize
    from transfer.style_config import strength_settings
    from video2style.pipeline import MAX_CLIP_SECONDS

    t0 = time.time()
    span = SPAN_FRAMES if span is None else span  # the module's, read at the call (tests make them small)
    margin = MARGIN if margin is None else margin
    path, out_dir = Path(path), Path(out_dir)
    frames = BvhFrames(path)
    if frames.num_frames / frames.fps > MAX_CLIP_SECONDS:
        raise ValueError(f"{path}: {frames.num_frames / frames.fps / 3600:.1f} hours long ({frames.num_frames} frames "
                         f"at {frames.fps:g} fps); clips up to {MAX_CLIP_SECONDS / 3600:g} hours are taken: split it")
    n = resampled_frames(frames.num_frames, frames.fps, CANONICAL.fps)
    if n < 10:
        raise ValueError(f"{path}: too short ({n} frames at {CANONICAL.fps:g} fps; need at least 10)")
    span = max(int(span), 2 * margin + 2)
    first = frames[0:min(frames.num_frames, 2_000)]
    rig = make_rig(frames.skeleton, first, joint_map, source=str(path))
    take = _Take(frames, rig, n)

    # pass 1: the floor and the feet's lowest heights, a span at a time
    lowest, feet_min = torch.empty(n), None
    for a in range(0, n, span):
        part = take.canonical(a, min(n, a + span))
        lowest[a:a + part.num_frames] = lowest_feet(part)
        m = part.global_positions()[:, list(CANONICAL.feet), 1].amin(0)
        feet_min = m if feet_min is None else torch.minimum(feet_min, m)
    take.shift = floor_shift(lowest)
    feet_min = feet_min - take.shift
    del lowest

    m = load_models(model_device(model))
    learned, config = style.configs()
    step, config = strength_settings(strength, learned, config, style.gain)
    head = take.canonical(0, min(n, 200))
    neutral_text, detected = None, None
    if neutralize != "never":  # the reading is of the first 8 s (read_motion)
        reading, neutral_text = apply_mod.neutral_caption(m.motion_encoder, m.text_encoder,
                                                          m.normalize(encode(head, floor=feet_min)), neutralize)
        detected = reading.describe()
    p0 = head.global_positions()[:1].double()
    state = (0, float(facing_angle(p0)[0]), (float(p0[0, 0, 0]), float(p0[0, 0, 2])))  # frame, yaw, xz
    del head

    device = model_device(model)
    scheduler = m.scheduler
    batch = apply_mod.WINDOW_BATCH
    streams = []
    if neutral_text is not None and config.neutralize_step > 0:
        gen_n = torch.Generator().manual_seed(seed + 1)
        text = neutral_text.to(device)
        streams.append(WindowStream(lambda p, i: neutralize_windows(
            m.prior, scheduler, p, text.expand(p.shape[0], -1), learned, gen_n, config.neutralize_step), n, batch))
    gen = torch.Generator().manual_seed(seed)
    streams.append(WindowStream(lambda p, i: stylize(model, scheduler, p, learned, config, gen, step=step, prior=m.prior), n, batch))
    rvel = FEATURES.root_rvel

    content = _Buffer()  # canonical content frames, from content.start on
    styled = _Buffer()  # stylised (unnormalised) features
    sums = {"skating_before": 0.0, "skating_after": 0.0, "skating_content": 0.0}
    out_path = out_dir / f"{path.stem}.bvh"
    spans = 0
    from video2style.preview import MAX_PREVIEW_SECONDS

    shown = min(n, int(MAX_PREVIEW_SECONDS * CANONICAL.fps)) if preview else 0
    kept = {"content": [], "result": [], "written": []}  # the previewed frames
    with BvhSpanWriter(out_path, frames.skeleton, frames.layout, frames.num_frames, frames.fps) as writer:
        c = 0  # the next canonical frame to write
        for a in range(0, n, span):
            b = min(n, a + span)
            e0, e1 = max(0, a - 1), min(n, b + 1)
            part = take.canonical(e0, e1)
            feats = m.normalize(encode(part, floor=feet_min))[a - e0:b - e0]
            content.append(part.slice(a - e0, b - e0))
            x = feats.to(device)
            for s in streams:
                x = s.feed(x)
            styled.append(m.denormalize(x.cpu(), inplace=True))
            while c < n and (styled.end >= min(n, c + span + margin)):
                d = min(n, c + span)
                lo, hi = max(0, c - margin), min(n, d + margin)
                f_ext, ref = styled.get(lo, hi), content.get(lo, hi)
                g, yaw, xz = state
                if g != lo:
                    raise RuntimeError(f"long take: the decode's start is frame {g}, expected {lo}")
                raw = apply_mod.decoder(config, reference=ref)(f_ext, CANONICAL.fps, start_yaw=yaw, start_xz=xz)
                cleaned = cleanup_feet(raw, reference=ref, floor=feet_min)
                keep = slice(c - lo, d - lo)
                k = d - c
                sums["skating_before"] += motion_skating(raw.slice(keep.start, keep.stop)) * k
                sums["skating_after"] += motion_skating(cleaned.slice(keep.start, keep.stop)) * k
                sums["skating_content"] += motion_skating(ref.slice(keep.start, keep.stop)) * k
                k0, k1 = take.source_frames(c, d)
                if k1 > k0:
                    per = CANONICAL.fps / frames.fps
                    on_file = carry_edit(frames[k0:k1], ref, cleaned, rig, offset=k0 * per - lo)
                    writer.append(on_file)
                    if c < shown:
                        kept["written"].append(on_file)
                if c < shown:
                    kept["content"].append(ref.slice(c - lo, min(d, shown) - lo))
                    kept["result"].append(cleaned.slice(c - lo, min(d, shown) - lo))
                nxt = max(0, d - margin)  # the next span's context starts here: the root's state there
                i = nxt - lo
                yaw = yaw + float(f_ext[:i, rvel][:, 0].double().sum())
                state = (nxt, yaw, (float(raw.lpos[i, 0, 0]), float(raw.lpos[i, 0, 2])))
                content.drop(nxt)
                styled.drop(nxt)
                c, spans = d, spans + 1
    info = {"input": str(path), "frames": n, "detected": detected, "neutralized": neutral_text is not None,
            **{k: v / n for k, v in sums.items()}, "tempo": 1.0, "streamed": spans,
            "seconds_transfer": time.time() - t0, "output": str(out_path),
            "stream_note": f"a take over {LONG_TAKE_SECONDS / 60:g} min: applied {spans} span(s) of up to "
                           f"{span / CANONICAL.fps / 60:g} min at a time (memory does not grow with the take); "
                           "no stray-limb guard, posture match, arm gate, arm hold or content keeper (they run on the whole clip)"}
    if preview:
        made = [out_path]
        try:
            info.update(_preview(style, path, rig, frames.layout, kept, shown, n, out_dir, made))
        except BaseException:
            for p in made:
                p.unlink(missing_ok=True)
            raise
    info["seconds"] = time.time() - t0
    return info


def _preview(style, path: Path, rig, layout, kept: dict, shown: int, n: int, out_dir: Path, made: list) -> dict:
    """The preview and player of a long take's first ``shown`` frames (:func:`video2style.pipeline.write_preview`)."""
    from video2style.pipeline import Clip, as_written, example_motion, write_preview

    def joined(parts: list[Motion]) -> Motion:
        return Motion(parts[0].skeleton, torch.cat([p.lrot for p in parts]), torch.cat([p.lpos for p in parts]),
                      parts[0].fps)

    content, result = joined(kept["content"]), joined(kept["result"])
    clip = Clip(path, content, rig, layout, None)
    ex = example_motion(style, shown)
    extra = [] if ex is None else [(ex, f"style: {style.meta.get('style', '')}")]
    info = write_preview(clip, [(as_written(clip, result, joined(kept["written"])), "result")], out_dir, extra, made)
    if shown < n:
        info["preview_note"] = f"the preview shows the first {shown / CANONICAL.fps:g} s of {n / CANONICAL.fps:.0f} s"
    return info


class _Buffer:
    """Frames of a take from ``start`` to ``end``: tensors ``(k, D)`` or canonical motions, appended in order,
    dropped from the front."""

    def __init__(self):
        self.parts, self.start, self.end = [], 0, 0

    def append(self, x) -> None:
        k = x.num_frames if isinstance(x, Motion) else x.shape[0]
        if k:
            self.parts.append(x)
            self.end += k

    def get(self, lo: int, hi: int):
        if lo < self.start or hi > self.end:
            raise RuntimeError(f"long take: frames {lo}-{hi} asked of {self.start}-{self.end}")
        whole = self._joined()
        off = self.start
        return whole.slice(lo - off, hi - off) if isinstance(whole, Motion) else whole[lo - off:hi - off]

    def drop(self, before: int) -> None:
        if before <= self.start:
            return
        whole = self._joined()
        k = before - self.start
        self.parts = [whole.slice(k, whole.num_frames) if isinstance(whole, Motion) else whole[k:].clone()]
        if isinstance(whole, Motion):
            self.parts = [Motion(whole.skeleton, whole.lrot[k:].clone(), whole.lpos[k:].clone(), whole.fps)]
        self.start = before

    def _joined(self):
        if len(self.parts) > 1:
            p = self.parts
            self.parts = [Motion(p[0].skeleton, torch.cat([q.lrot for q in p]), torch.cat([q.lpos for q in p]), p[0].fps)
                          if isinstance(p[0], Motion) else torch.cat(p)]
        return self.parts[0]
