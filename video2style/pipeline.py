"""Orchestration of learn / apply over files: reading inputs, models, writing BVH and previews."""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import torch

from motioncore.bvh import BvhLayout, read_bvh, write_bvh
from motioncore.motion import Motion, resample
from motioncore.representation import decode, encode
from motioncore.retarget import (
    Rig,
    from_canonical,
    make_rig,
    place_on_floor,
    to_canonical,
)
from motioncore.skeleton import CANONICAL
from video2style.paths import PACKAGE_ROOT

WEIGHTS = PACKAGE_ROOT / "transfer" / "weights"
VIDEO_SUFFIXES = {".mp4", ".mov", ".avi", ".mkv", ".webm", ".m4v"}


def weights_path(name: str) -> Path:
    """A model file: ``$VIDEO2STYLE_WEIGHTS/name`` if set, else the weights shipped with the package."""
    base = Path(os.environ.get("VIDEO2STYLE_WEIGHTS", WEIGHTS))
    path = base / name
    if not path.is_file():
        raise FileNotFoundError(f"{path}: model weights missing (train them with video2style train-prior / train-encoder, "
                                "or set VIDEO2STYLE_WEIGHTS to a folder holding them)")
    return path


@dataclass
class Models:
    prior: torch.nn.Module
    mean: torch.Tensor
    std: torch.Tensor
    motion_encoder: torch.nn.Module
    text_encoder: object
    prior_path: Path


@lru_cache(maxsize=1)
def load_models() -> Models:
    from transfer.motion_encoder import load_motion_encoder
    from transfer.prior import load_prior
    from transfer.text_encoder import default_text_encoder

    prior_path = weights_path("denoiser.safetensors")
    prior, mean, std = load_prior(prior_path)
    encoder = load_motion_encoder(weights_path("motion_encoder.safetensors"))
    return Models(prior, mean, std, encoder, default_text_encoder(), prior_path)


def prior_samples(captions: list[str], frames: int = 80, seed: int = 0, steps: int = 50, guidance: float = 2.5) -> list[Motion]:
    """Text-to-motion samples of the shipped prior, one per caption, as canonical motions standing on the floor."""
    from transfer.sampling import generate
    from transfer.scheduler import DiffusionScheduler

    m = load_models()
    gen = torch.Generator().manual_seed(seed)
    x = generate(m.prior, DiffusionScheduler(m.prior.config.num_train_steps), m.text_encoder.encode(captions), frames,
                 steps, guidance, gen)
    return [place_on_floor(decode(f * m.std + m.mean)) for f in x]


@dataclass
class Clip:
    """An input clip on the canonical skeleton at the canonical fps, and how to write results back."""

    path: Path
    canonical: Motion
    rig: Rig | None = None
    layout: BvhLayout | None = None
    fps: float = CANONICAL.fps


def read_clip(path: Path, joint_map: dict | None = None, progress=None) -> Clip:
    """A BVH (any supported skeleton) or a video (via the lifting pipeline) -> :class:`Clip`."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    if path.suffix.lower() in VIDEO_SUFFIXES:
        from lifting.pipeline import video_to_motion

        canon = video_to_motion(path, progress=progress)
        return Clip(path, resample(canon, CANONICAL.fps), fps=canon.fps)
    motion, layout = read_bvh(path)
    rig = make_rig(motion.skeleton, motion, joint_map, source=str(path))
    canon = place_on_floor(to_canonical(resample(motion, CANONICAL.fps), rig))
    if canon.num_frames < 10:
        raise ValueError(f"{path}: too short ({canon.num_frames} frames at {CANONICAL.fps:g} fps; need at least 10)")
    return Clip(path, canon, rig, layout, motion.fps)


def write_result(clip: Clip, result: Motion, out_path: Path) -> Path:
    """Write ``result`` (canonical) as BVH on the clip's own skeleton and frame rate when it has one."""
    if clip.rig is not None:
        motion = resample(from_canonical(result, clip.rig), clip.fps)
        write_bvh(out_path, motion, clip.layout)
    else:
        write_bvh(out_path, result, BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    return out_path


def example_motion(style) -> Motion | None:
    """The style example stored in a style file, decoded for previews."""
    return None if style.example is None else decode(style.example.float())


def elapsed(t0: float) -> str:
    return f"{time.time() - t0:.1f} s"


def content_source(progress=print):
    """Neutral content motions for style learning: the dataset cache if present, else the shipped bank."""
    from transfer.content_bank import ContentBank
    from transfer.dataset import MotionDataset
    from video2style.paths import default_dataset_dir

    data_dir = Path(os.environ.get("VIDEO2STYLE_DATA", default_dataset_dir()))
    if (data_dir / "features.safetensors").is_file():
        progress(f"      content motions: dataset cache {data_dir}")
        return MotionDataset(data_dir, "train")
    progress("      content motions: the bundled content bank (no dataset cache found)")
    return ContentBank(weights_path("content_bank.safetensors"))


def learn_file(path: Path, out_path: Path, style_words: str | None = None, text: str | None = None,
               config=None, joint_map: dict | None = None, progress=print) -> dict:
    """Learn a style from a video or BVH and save it to ``out_path``; returns a summary."""
    from transfer.apply import classify_caption
    from transfer.style import StyleConfig, learn_style

    t0 = time.time()
    config = config or StyleConfig()
    style_words = style_words or Path(path).stem.replace("_", " ").replace("-", " ")
    progress(f"[1/4] reading {path}")
    clip = read_clip(path, joint_map, progress=progress)
    progress(f"      {clip.canonical.num_frames} frames on the canonical skeleton ({elapsed(t0)})")
    m = load_models()
    example = (encode(clip.canonical) - m.mean) / m.std
    if text is None:
        content, _, top = classify_caption(m.motion_encoder, m.text_encoder, example)
        text = content
        progress(f"[2/4] content by retrieval: {content!r} (nearest captions {top[0][0]!r}, {top[1][0]!r})")
    else:
        progress(f"[2/4] content given: {text!r}")
    dataset = content_source(progress)
    progress("[3/4] learning")
    style, _ = learn_style(m.prior, m.motion_encoder, m.text_encoder, dataset, example, style_words, text, config,
                              m.prior_path, progress=lambda s: progress(f"      {s}"))
    style.example = encode(clip.canonical)
    style.meta.update({"source": Path(path).name, "example_seconds": round(clip.canonical.duration, 2)})
    progress(f"[4/4] writing {out_path}")
    style.save(out_path)
    return {"style": style_words, "content": style.meta["content"], "seconds": time.time() - t0,
            "iterations": style.meta["iterations"], "bytes": Path(out_path).stat().st_size}


def apply_file(style, model, path: Path, out_dir: Path, step: int, seed: int = 0, neutralize: str = "auto",
               joint_map: dict | None = None, preview: bool = True) -> dict:
    """Apply a loaded style (``model`` = prior + adapters) to one BVH; writes ``out_dir/<name>.bvh`` (+ preview)."""
    from transfer.apply import apply_style_motion, classify_caption
    from transfer.captions import content_caption
    from transfer.style import StyleConfig

    t0 = time.time()
    m = load_models()
    clip = read_clip(path, joint_map)
    config = StyleConfig(**style.meta.get("config", {}))
    neutral_text, detected = None, None
    if neutralize != "never":
        content, style_label, _ = classify_caption(m.motion_encoder, m.text_encoder, (encode(clip.canonical) - m.mean) / m.std)
        detected = f"{content}/{style_label}"
        if neutralize == "always" or style_label != "normal":
            neutral_text = m.text_encoder.encode([content_caption(content)])
    raw = apply_style_motion(model, m.prior, clip.canonical, m.mean, m.std, config, step, seed, neutral_text, clean=False)
    result, skating = clean_feet(raw, clip.canonical)
    ex = example_motion(style)
    extra = [] if ex is None else [(ex, f"style: {style.meta.get('style', '')}")]
    info = {"input": str(path), "frames": clip.canonical.num_frames, "detected": detected,
            "neutralized": neutral_text is not None, "seconds_transfer": time.time() - t0, **skating}
    info.update(write_outputs(clip, [(result, "result")], Path(out_dir), extra, preview))
    info["seconds"] = time.time() - t0
    return info


def clean_feet(motion: Motion, content: Motion) -> tuple[Motion, dict]:
    """IK foot cleanup against the content's contacts; returns the motion and the foot-skating ratio before/after."""
    from motioncore.cleanup import cleanup_feet
    from transfer.metrics import foot_skating_ratio

    cleaned = cleanup_feet(motion, reference=content)
    return cleaned, {"skating_before": foot_skating_ratio(motion.global_positions(), motion.fps),
                     "skating_after": foot_skating_ratio(cleaned.global_positions(), cleaned.fps)}


def write_outputs(clip: Clip, results: list[tuple[Motion, str]], out_dir: Path, extra: list[tuple[Motion, str]] = (),
                  preview: bool = True) -> dict:
    """Write each ``(result, tag)`` as BVH on the clip's skeleton (``<name>.bvh`` for one result, else
    ``<name>_<tag>.bvh``) and one preview mp4: content | extra panels | results. Returns the paths."""
    stem = Path(clip.path).stem
    outputs = []
    for motion, tag in results:
        name = f"{stem}.bvh" if len(results) == 1 else f"{stem}_{tag}.bvh"
        outputs.append(str(write_result(clip, motion, Path(out_dir) / name)))
    info = {"output": outputs[0] if len(outputs) == 1 else outputs}
    if preview:
        from motioncore.render import Panel, render_video

        sk = CANONICAL.skeleton
        panels = [Panel(m.global_positions(), sk.parents, label, names=sk.names)
                  for m, label in [(clip.canonical, "content"), *extra, *results]]
        size = (360, 360) if len(panels) <= 4 else (280, 280)
        info["preview"] = str(render_video(panels, Path(out_dir) / f"{stem}_preview.mp4", CANONICAL.fps, size=size, progress=False))
    return info
