"""A learned style loaded with the method's models, as one object: :class:`LoadedStyle`, made from a style file
through the one models' bundle (:meth:`LoadedStyle.from_file`, as diffusers' ``from_pretrained`` makes a pipeline
from its parts), asked with the one request (:class:`video2style.options.ApplyOptions`) and answering with the one
result (:class:`video2style.result.ApplyResult`)::

    style = LoadedStyle.from_file("old.v2s")                      # the shipped models, on the CPU
    result = style.apply(Path("walk.bvh"), Path("out"), ApplyOptions(strength=0.6))
    print(result.output, result.skating_after)
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import torch

from motioncore.motion import Motion
from video2style.options import ApplyOptions
from video2style.result import ApplyResult


@dataclass(frozen=True)
class LoadedStyle:
    """A style (:class:`transfer.style_file.Style`) with the models it is applied with: ``bundle``
    (:class:`transfer.bundle.MethodBundle`: the prior, the encoders, the features' normalisation) and ``model``
    (a copy of the bundle's prior with the style's adapters, :func:`transfer.style_file.style_model`), on the
    bundle's device."""

    style: object
    bundle: object
    model: torch.nn.Module

    @classmethod
    def from_file(cls, path: str | Path, bundle=None, device: str = "cpu") -> LoadedStyle:
        """The style file ``path`` read and validated (:meth:`transfer.style_file.Style.load`: one-line
        ValueErrors) and loaded on ``bundle`` (default: the shipped models on ``device``,
        :func:`transfer.bundle.load_models`)."""
        from transfer.style_file import Style

        return cls.from_style(Style.load(Path(path)), bundle, device)

    @classmethod
    def from_style(cls, style, bundle=None, device: str = "cpu") -> LoadedStyle:
        """A style in memory (:class:`transfer.style_file.Style`) loaded as :meth:`from_file` loads one."""
        from transfer.bundle import load_models
        from transfer.style_file import style_model

        bundle = load_models(device) if bundle is None else bundle
        return cls(style, bundle, style_model(bundle.prior, style))

    @property
    def path(self) -> Path | None:
        """The style file it was read from (None for a style made in memory)."""
        return self.style.source

    def warning(self) -> str | None:
        """A one-line warning when the style was learned on another prior than the installed one
        (:func:`transfer.bundle.base_model_warning`), else None."""
        from transfer.bundle import base_model_warning

        return base_model_warning(self.style, self.path)

    def describe(self, strength: float) -> str:
        """The style in a few words for the results page and ``report.json``: its name, what it was learned from and
        in how many iterations, and the strength it is applied at."""
        meta = getattr(self.style, "meta", {}) or {}
        facts = [f"style {meta.get('style', '?')!s}"]
        if meta.get("source"):
            facts.append(f"learned from {meta['source']}")
        if meta.get("iterations") is not None:
            facts.append(f"{meta['iterations']} iterations")
        return ", ".join(facts) + f"; applied at strength {strength:g}"

    def stylize(self, motion: Motion, request: ApplyOptions = ApplyOptions()) -> tuple[Motion, dict]:
        """A canonical content motion (canonical fps, ``T`` frames) stylised as ``request`` says (its ``strength``,
        ``seed``, ``neutralize`` and ``feet``; :func:`transfer.spans.stylize_motion`): the result (``T`` frames on the
        same path, on the CPU) and what the method decided (``detected``, ``neutralized``, the skating ratios, whether
        the feet were cleaned, the toes' swing clearance, the guards' shares: :class:`video2style.result.ApplyResult`'s
        fields of those names)."""
        from transfer.spans import stylize_motion

        return stylize_motion(self.bundle, self.style, self.model, motion, request.strength, request.seed,
                              request.neutralize, request.feet)

    def spans(self, content, n: int, request: ApplyOptions, **kw):
        """:func:`transfer.spans.stylize_spans` of this style at ``request``'s ``strength``, ``seed``,
        ``neutralize`` and ``feet``: a canonical motion of ``n`` frames given by ``content(a, b)``, styled a span at a
        time (``kw``: ``floor``, ``span``, ``margin``, ``report``, ``content_acc``)."""
        from transfer.spans import stylize_spans

        return stylize_spans(self.bundle, self.style, self.model, content, n, request.strength, request.seed,
                             request.neutralize, feet=request.feet, **kw)

    def apply(self, path: Path, out_dir: Path, request: ApplyOptions = ApplyOptions(),
              joint_map: dict | None = None) -> ApplyResult:
        """The style applied to one BVH clip (or video) as ``request`` says: writes ``out_dir/<name>.bvh`` on the
        clip's skeleton (+ its preview and player data unless ``request.preview`` is off). ``request.tempo`` (see
        :func:`transfer.tempo.resolve_tempo`): the clip is first time-warped to play this many times as fast
        (0.7: slower, more frames; the path is the same; the feet are cleaned against the warped content's contacts).
        ``request.feet``: auto, lock or off (:func:`transfer.spans.clean_feet`). A BVH take longer than
        :data:`video2style.long_takes.LONG_TAKE_SECONDS` at tempo 1 is applied a span at a time
        (:func:`video2style.long_takes.apply_long_bvh`). ``joint_map``: the map ``request.joint_map`` names, as read
        (:func:`motioncore.retarget.load_joint_map`) by a caller that reads it once before any work, as the commands
        do; None: read here."""
        from motioncore.retarget import load_joint_map
        from transfer.tempo import resolve_tempo
        from video2style.long_takes import (
            LONG_TAKE_SECONDS,
            apply_long_bvh,
            is_long_take,
        )
        from video2style.pipeline import (
            BVH_SUFFIX,
            example_panels,
            read_clip,
            warp_clip,
            write_long_take_preview,
            write_outputs,
        )
        from video2style.summary import motion_change

        t0 = time.time()
        if joint_map is None and request.joint_map is not None:
            joint_map = load_joint_map(request.joint_map)
        speed = resolve_tempo(self.style, request.tempo)
        long_take = Path(path).suffix.lower() == BVH_SUFFIX and is_long_take(path)
        if long_take and speed == 1.0:  # a span at a time: memory does not grow with the take (issue 25)
            result, shown = apply_long_bvh(self, path, out_dir, request, joint_map)
            if shown is not None:
                result.add_files(write_long_take_preview(self.style, Path(path), shown, result.output, result.frames,
                                                         Path(out_dir)))
            result.seconds = time.time() - t0
            return result
        clip = warp_clip(read_clip(path, joint_map), speed)
        styled, decided = self.stylize(clip.canonical, request)
        extra = example_panels(self.style, clip.canonical.num_frames)
        result = ApplyResult(str(path), frames=clip.canonical.num_frames, **decided, tempo=speed,
                             seconds_transfer=time.time() - t0, rolls_conformed=clip.rolls_conformed,
                             change=motion_change(clip.canonical, styled),
                             # the written file's own length (a BVH's frames and frame rate; a video's: canonical)
                             file_frames=clip.canonical.num_frames if clip.source is None else clip.source.num_frames,
                             file_fps=(clip.canonical if clip.source is None else clip.source).fps)
        if long_take:
            result.stream_note = (f"applied whole (--tempo {speed:g}): takes over {LONG_TAKE_SECONDS / 60:g} min are "
                                  "applied a span at a time only at --tempo 1; memory grows with this take")
        written = write_outputs(clip, [(styled, "result")], Path(out_dir), extra, request.preview)
        result.add_files(written)
        result.seconds = time.time() - t0
        return result
