"""Orchestration of learn / apply over files: reading inputs, models, writing BVH and previews (the style applied
to a clip: :meth:`video2style.loaded_style.LoadedStyle.apply`)."""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import torch

from mlcore.shipped import weights_path
from motioncore.bvh import BvhLayout, read_bvh, write_bvh
from motioncore.ik_fit import conform_rolls, off_roll_convention
from motioncore.motion import Motion, resample, time_warp, trim
from motioncore.representation import decode, encode
from motioncore.retarget import Rig, carry_edit, make_rig, place_on_floor, to_canonical
from motioncore.skeleton import CANONICAL
from transfer.bundle import load_models
from transfer.sampling import TEXT_TO_MOTION, TextToMotion
from video2style.clip_limits import check_frames, check_length

VIDEO_SUFFIXES = {".mp4", ".mov", ".avi", ".mkv", ".webm", ".m4v"}
BVH_SUFFIX = ".bvh"


def prior_samples(captions: list[str], frames: int = 80, seed: int = 0, settings: TextToMotion = TEXT_TO_MOTION,
                  device: str = "cpu", from_positions: bool = False) -> list[Motion]:
    """Text-to-motion samples of the shipped prior (run on ``device``, drawn as ``settings`` say), one per caption,
    as canonical motions standing on the floor. ``from_positions``: the rotations fitted to the samples' joint-position channels
    (:func:`motioncore.ik_fit.decode_via_positions`), whose feet the prior places better than its rotation
    channels do (docs/archive/RESULTS-notebook.md#found-while-checking-the-demo-the-priors-walks-shuffle-2026-12-02);
    else decoded from the rotation channels."""
    from motioncore.ik_fit import decode_via_positions

    m = load_models(device)
    x = m.text_to_motion(m.text_encoder.encode(captions), frames, torch.Generator().manual_seed(seed), settings).cpu()
    to_motion = (lambda f: decode_via_positions(f, CANONICAL.fps)) if from_positions else decode
    return [place_on_floor(to_motion(m.denormalize(f))) for f in x]


@dataclass
class Clip:
    """An input clip on the canonical skeleton at the canonical fps, and how to write results back: the
    motion as read (``source``, on its own skeleton and fps), its rig and BVH layout (None for videos);
    ``rolls_conformed``: its rig's bone rolls were off the models' convention and its rotations were solved again
    (:func:`motioncore.ik_fit.conform_rolls`)."""

    path: Path
    canonical: Motion
    rig: Rig | None = None
    layout: BvhLayout | None = None
    source: Motion | None = None
    rolls_conformed: bool = False


def warp_clip(clip: Clip, tempo: float) -> Clip:
    """The clip played ``tempo`` times as fast (:func:`motioncore.motion.time_warp`), its source too."""
    if tempo == 1.0:
        return clip
    source = None if clip.source is None else time_warp(clip.source, tempo)
    return Clip(clip.path, time_warp(clip.canonical, tempo), clip.rig, clip.layout, source, clip.rolls_conformed)


def find_bvh_files(folder: Path, recursive: bool = True) -> list[Path]:
    """The BVH files in ``folder`` (its subfolders too, unless ``recursive`` is False), any case of ``.bvh``,
    sorted: the one way every command finds its clips."""
    found = Path(folder).rglob("*") if recursive else Path(folder).glob("*")
    return sorted(p for p in found if p.suffix.lower() == BVH_SUFFIX and p.is_file())


def content_clips(folder: Path, out_dir: Path | None = None, notify=None, *, protected: list | None = None) -> list[Path]:
    """:func:`find_bvh_files` in ``folder`` less results, which are never read back as content: the output folder
    ``out_dir`` where it lies inside ``folder``, and any subfolder holding a ``.video2style.lock`` (an earlier
    batch's or apply's output folder). ``notify(line)`` hears what was left out. ``protected``, a list, receives
    the clips left out that no run of ours wrote (in ``out_dir`` before it was ever locked): the user's, so no
    output may overwrite them (:func:`video2style.paths.check_outputs`)."""
    from video2style.paths import LOCK_NAME, inside, same_path

    folder = Path(folder)
    clips = find_bvh_files(folder)
    marked = [lock.parent for lock in folder.rglob(LOCK_NAME) if lock.parent != folder]
    results = list(marked)
    if out_dir is not None and inside(out_dir, folder) and not same_path(out_dir, folder):
        results.append(Path(out_dir))
    kept = [c for c in clips if not any(inside(c, r) for r in results)]
    if protected is not None and len(kept) < len(clips):
        taken = set(kept)
        protected += [c for c in clips if c not in taken and not any(inside(c, r) for r in marked)]
    if len(kept) < len(clips) and notify is not None:
        notify(f"{folder}: left out {len(clips) - len(kept)} clip(s) in output folders "
               f"({', '.join(sorted({str(r) for r in results}))}): results are not read back as content")
    return kept


def read_clip(path: Path, joint_map: dict | None = None, progress=None,
              span: tuple[float | None, float | None] = (None, None), rotate: int | None = None) -> Clip:
    """A BVH (any supported skeleton) or a video (via the lifting pipeline) -> :class:`Clip`.

    ``span = (start, end)`` in seconds (None: from the beginning / to the end) keeps only that part.
    ``rotate``: a video's frames turned this many degrees clockwise before tracking (see
    :func:`lifting.lift.lift_video`; None: as they are, a turned person refused); not for a BVH.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    if path.suffix.lower() in VIDEO_SUFFIXES:
        from lifting.lift import video_to_motion

        canon = video_to_motion(path, progress=progress, span=span, rotate=rotate)
        return Clip(path, resample(canon, CANONICAL.fps))
    if rotate is not None:
        raise ValueError(f"{path}: --rotate turns a video's frames; this is not a video")
    motion, layout = read_bvh(path)
    check_length(path, motion.num_frames, motion.fps)
    rig = make_rig(motion.skeleton, motion, joint_map, source=str(path))
    if span != (None, None):
        motion = trim(motion, span, str(path))
    canon = to_canonical(resample(motion, CANONICAL.fps), rig)
    conformed = off_roll_convention(canon)
    canon = place_on_floor(conform_rolls(canon, force=conformed))
    check_frames(path, canon.num_frames)
    return Clip(path, canon, rig, layout, motion, conformed)


def write_result(clip: Clip, result: Motion, out_path: Path) -> Motion | None:
    """Write ``result`` (canonical, frame for frame with ``clip.canonical``) as BVH. A BVH clip keeps its own
    skeleton, joints, channels, frame time and frame count (:func:`motioncore.retarget.carry_edit`), so each
    bone keeps the content's twist. Returns the motion written on the clip's skeleton (None for a video)."""
    if clip.rig is None:
        write_bvh(out_path, result, BvhLayout.default(CANONICAL.skeleton, scale=0.01))
        return None
    written = carry_edit(clip.source, clip.canonical, result, clip.rig)
    write_bvh(out_path, written, clip.layout)
    return written


def as_written(clip: Clip, result: Motion, written: Motion | None) -> Motion:
    """``result`` with the rotations :func:`write_result` wrote (the content's twist), for previews."""
    if written is None:
        return result
    lrot = resample(to_canonical(written, clip.rig), CANONICAL.fps).lrot
    idx = torch.arange(result.num_frames).clamp(max=lrot.shape[0] - 1)
    return Motion(result.skeleton, lrot[idx], result.lpos, result.fps)


# what a user is told when a clip's rig rolls its bones its own way (learn's reading line, apply's notes)
ROLLS_NOTE = "its rig rolls its bones its own way: the models read rotations solved again from its joint positions"


def example_motion(style, frames: int | None = None) -> Motion | None:
    """The style example stored in a style file, decoded for previews: its first ``frames`` frames (None: all),
    so that a long example costs a preview no more than the clip beside it does."""
    return None if style.example is None else decode(style.example[:frames].float())


def elapsed(t0: float) -> str:
    return f"{time.time() - t0:.1f} s"


def content_source(progress=print):
    """Neutral content motions for style learning: the dataset cache if present, else the shipped bank."""
    from mlcore.dataset import MotionDataset
    from transfer.content_bank import ContentBank
    from video2style.paths import default_dataset_dir

    data_dir = Path(os.environ.get("VIDEO2STYLE_DATA", default_dataset_dir()))
    if (data_dir / "features.safetensors").is_file():
        progress(f"      content motions: dataset cache {data_dir}")
        return MotionDataset(data_dir, "train")
    progress("      content motions: the bundled content bank (no dataset cache found)")
    return ContentBank(weights_path("content_bank.safetensors"))


class PartialStyleError(ValueError):
    """Learning ended before the style was complete (time cap, or too few iterations); nothing was written."""


def learn_file(path: Path, out_path: Path, style_words: str | None = None, text: str | None = None,
               config=None, joint_map: dict | None = None, progress=print, *, allow_partial: bool = False,
               span: tuple[float | None, float | None] = (None, None), show_bar: bool = False,
               device: str = "cpu", rotate: int | None = None, apply_config=None) -> dict:
    """Learn a style from a video or BVH on ``device`` (:func:`transfer.bundle.load_models`) and save it to ``out_path``;
    returns a summary. The noise is drawn on the CPU whatever the device, so a GPU's style differs from the
    CPU's only by the GPU's arithmetic (and its dropout draws).

    ``config``: the :class:`transfer.style_config.LearnConfig` (default: today's); ``apply_config``: the apply
    settings the style file records (:class:`transfer.style_config.ApplyConfig`, default: today's).
    If learning is cut short by ``config.max_seconds`` or runs fewer than
    :data:`transfer.style_config.MIN_ITERATIONS` iterations, raises :class:`PartialStyleError` and writes
    nothing, unless ``allow_partial`` (then the summary's ``partial`` holds the reason).
    ``span``: ``(start, end)`` seconds of the input to learn from; ``rotate``: a video's frames turned
    this many degrees clockwise (:func:`read_clip`).
    """
    from transfer.apply import read_motion
    from transfer.learn import learn_style, partial_reason
    from transfer.style_config import LearnConfig
    from transfer.style_file import file_sha256
    from transfer.tempo import style_tempo

    t0 = time.time()
    config = config or LearnConfig()
    style_words = style_words or Path(path).stem.replace("_", " ").replace("-", " ")
    progress(f"[1/4] reading {path}")
    if Path(path).suffix.lower() in VIDEO_SUFFIXES:
        _announce_long_video(Path(path), span, progress)
    clip = read_clip(path, joint_map, progress=progress, span=span, rotate=rotate)
    read, src = clip.canonical, clip.source  # what each number is: the file's own frames, then the canonical ones
    if src is not None:
        length = f"{src.duration:.2f} s: {src.num_frames} frames at {src.fps:g} fps in the file"
    elif span == (None, None):  # a video, whole: its own frames (tracking may start where the person is first seen)
        from lifting.video import video_info

        fps, frames, _, _ = video_info(Path(path))
        length = f"{frames / fps:.2f} s: {frames} frames at {fps:g} fps in the video"
    else:
        length = f"{read.duration:.2f} s of motion tracked"
    progress(f"      {length} ({read.num_frames} frames at {read.fps:g} fps on the canonical skeleton; read in "
             f"{elapsed(t0)})" + (f"; {ROLLS_NOTE}" if clip.rolls_conformed else ""))
    m = load_models(device)
    features = m.normalize(encode(clip.canonical), inplace=True)  # in place: a long take's features once
    bvh = clip.rig is not None  # a video's motion starts where the person was first tracked
    canonical, used = example_part(clip.canonical, features, (span[0] or 0.0) if bvh else 0.0)
    del features
    if canonical is not clip.canonical:
        where = "of the input" if bvh else "from where the person was first tracked"
        progress(f"      learning from {used[0]:.1f}-{used[1]:.1f} s {where} ({clip.canonical.duration:.0f} s read): "
                 f"its most typical {MAX_EXAMPLE_SECONDS:g} s; --start/--end choose another part")
    example = m.normalize(encode(canonical))
    confident = True  # the content: given, or recognised with confidence (else a guess, said as one)
    if text is None:
        reading = read_motion(m.motion_encoder, m.text_encoder, example)
        text, confident = reading.content, bool(reading.confident)
        if confident:
            progress(f"[2/4] content by retrieval: {reading.content!r} (nearest captions {reading.top[0][0]!r}, "
                     f"{reading.top[1][0]!r}; confident)")
        else:
            progress(f"[2/4] content not recognised with confidence: learning against the closest guess "
                     f"{reading.content!r} (nearest captions {reading.top[0][0]!r}, {reading.top[1][0]!r}); "
                     "give --text to say what the person does")
    else:
        progress(f"[2/4] content given: {text!r}")
    dataset = content_source(progress)
    progress("[3/4] learning")
    style, info = learn_style(m, dataset, example, style_words, text, config,
                              progress=lambda s: progress(f"      {s}"), show_bar=show_bar, apply=apply_config)
    from transfer.amount import describe_amount, style_distance

    a = style.meta.get("amount")
    if a is None and info.get("pair") is not None:
        a = {"gain": 1.0, "target": style_distance(example.cpu(), info["pair"]), "reached": None}
    if a is not None:
        progress(f"      {describe_amount(a['gain'], a['target'], a['reached'])}")
    tempo = style_tempo(canonical, text, dataset, m)
    if tempo is not None:
        progress(f"      tempo: the example moves {tempo:.2f} x as fast as neutral {text!r} clips (apply --tempo auto)")
    partial = partial_reason(style.meta)
    if partial and not allow_partial:
        raise PartialStyleError(f"{path}: {partial}; nothing written (give more time or iterations, "
                                "or --allow-partial to keep it)")
    style.example = encode(canonical)
    # the prior it was learned on, for transfer.bundle.base_model_warning
    style.meta["base_model_sha256"] = file_sha256(m.prior_path) if m.prior_path else None
    style.meta.update({"source": Path(path).name, "example_seconds": round(canonical.duration, 2),
                       "span": list(span), "example_part": [round(t, 2) for t in used], "partial": partial,
                       "tempo": tempo, "content_confident": confident})
    progress(f"[4/4] writing {out_path}")
    style.save(out_path)
    return {"style": style_words, "content": style.meta["content"], "content_confident": confident,
            "seconds": time.time() - t0,
            "iterations": style.meta["iterations"], "bytes": Path(out_path).stat().st_size, "partial": partial}


MAX_EXAMPLE_SECONDS = 20.0  # learning uses at most this much of its input: a 3-minute video took 16 minutes to
# learn whole (issue 25), most of it in the pair and the per-iteration work that grow with the example


def _announce_long_video(path: Path, span: tuple[float | None, float | None], progress) -> None:
    """Before tracking: say what a video longer than :data:`MAX_EXAMPLE_SECONDS` (within ``span``) will cost."""
    from lifting.video import video_info

    fps, frames, _, _ = video_info(path)
    start, end = span
    seconds = max(0.0, min(end if end is not None else frames / fps, frames / fps) - (start or 0.0))
    if seconds > MAX_EXAMPLE_SECONDS:
        progress(f"      {path.name}: {seconds:.0f} s of video ({seconds * fps:.0f} frames) to track first; learning "
                 f"then uses its most typical {MAX_EXAMPLE_SECONDS:g} s. To track and learn only a part: "
                 "--start/--end")


def example_part(canonical: Motion, features: torch.Tensor, offset: float = 0.0) -> tuple[Motion, tuple[float, float]]:
    """The part of a canonical example (and its normalised ``features (T, D)``) that learning uses: all of it
    up to :data:`MAX_EXAMPLE_SECONDS`, else its most typical window of that length
    (:func:`mlcore.windows.typical_window`, starts every second). Returns the motion (``canonical`` itself when
    whole) and its ``(start, end)`` in seconds of the input, ``offset`` being where ``canonical`` starts there."""
    from mlcore.windows import typical_window

    length = int(MAX_EXAMPLE_SECONDS * canonical.fps)
    if canonical.num_frames <= length:
        return canonical, (offset, offset + canonical.duration)
    start = typical_window(features, length, max(1, int(canonical.fps)))
    part = canonical.slice(start, start + length)
    return part, (offset + start / canonical.fps, offset + (start + length) / canonical.fps)


def example_panels(style, frames: int) -> list[tuple[Motion, str]]:
    """The style example's preview panel beside a clip of ``frames`` frames, no longer than it (none without one)."""
    ex = example_motion(style, frames)
    return [] if ex is None else [(ex, f"style: {style.meta.get('style', '')}")]


def write_long_take_preview(style, path: Path, shown, output: str, frames: int, out_dir: Path) -> dict:
    """The preview and player of a long take's first frames (``shown``: :class:`video2style.long_takes.Shown`;
    ``frames``: the take's canonical frames; :func:`write_preview`); when they fail, the take's ``output`` goes
    with them."""
    clip = Clip(path, shown.content, shown.rig, shown.layout)
    made = [Path(output)]
    try:
        preview = write_preview(clip, [(as_written(clip, shown.result, shown.written), "result")], out_dir,
                                example_panels(style, shown.content.num_frames), made)
    except BaseException:
        for p in made:
            p.unlink(missing_ok=True)
        raise
    if shown.content.num_frames < frames:
        preview["preview_note"] = (f"the preview shows the first {shown.content.num_frames / CANONICAL.fps:g} s of "
                                   f"{frames / CANONICAL.fps:.0f} s")
    return preview


def write_outputs(clip: Clip, results: list[tuple[Motion, str]], out_dir: Path, extra: list[tuple[Motion, str]] = (),
                  preview: bool = True) -> dict:
    """Write each ``(result, tag)`` as BVH on the clip's skeleton (``<name>.bvh`` for one result, else
    ``<name>_<tag>.bvh``) and one preview mp4: content | extra panels | results. Returns the paths: ``outputs``
    (a list, in the order of ``results``) and :func:`write_preview`'s.
    All of a clip's outputs or none: when one fails (a full disk), those this call wrote are removed."""
    made: list[Path] = []
    try:
        return _write_outputs(clip, results, Path(out_dir), extra, preview, made)
    except BaseException:
        for path in made:
            path.unlink(missing_ok=True)
        raise


def _write_outputs(clip: Clip, results: list[tuple[Motion, str]], out_dir: Path, extra: list[tuple[Motion, str]],
                   preview: bool, made: list[Path]) -> dict:
    stem = Path(clip.path).stem
    outputs, written = [], []
    for motion, tag in results:
        name = f"{stem}.bvh" if len(results) == 1 else f"{stem}_{tag}.bvh"
        on_file = write_result(clip, motion, Path(out_dir) / name)
        made.append(Path(out_dir) / name)
        if preview:
            written.append((as_written(clip, motion, on_file), tag))
        del on_file  # a long take's copy is not kept past its writing
        outputs.append(str(Path(out_dir) / name))
    info = {"outputs": outputs}
    if preview:
        info.update(write_preview(clip, written, out_dir, extra, made))
    return info


def write_preview(clip: Clip, written: list[tuple[Motion, str]], out_dir: Path, extra: list[tuple[Motion, str]],
                  made: list[Path]) -> dict:
    """The preview mp4 and player data of :func:`write_outputs` (content | extra panels | ``written``); the paths
    made are added to ``made``. Returns ``player``, ``preview`` and ``preview_note`` (when cut short)."""
    stem = Path(clip.path).stem
    info = {}
    from motioncore.kinematics import fk
    from motioncore.render import Panel, render_video, twist_markers

    sk = CANONICAL.skeleton

    def panel(m: Motion, label: str) -> Panel:
        grot, gpos = fk(m.lrot, m.lpos, sk.parents)
        return Panel(gpos, sk.parents, label, names=sk.names, markers=twist_markers(grot, sk.offsets, sk.parents))

    from video2style.preview import MAX_PREVIEW_SECONDS

    shown = [(m, label) for m, label in [(clip.canonical, "content"), *extra, *written]]
    if clip.canonical.duration > MAX_PREVIEW_SECONDS:
        shown = [(m.slice(0, int(MAX_PREVIEW_SECONDS * m.fps)), label) for m, label in shown]
        info["preview_note"] = f"the preview shows the first {MAX_PREVIEW_SECONDS:g} s of {clip.canonical.duration:.0f} s"
    panels = [panel(m, label) for m, label in shown]
    from video2style.results_page import write_player_data

    player = Path(out_dir) / f"{stem}_player.js"
    info["player"] = str(write_player_data(player, str(player.resolve()), shown))
    made.append(player)
    size = (360, 360) if len(panels) <= 4 else (280, 280)
    info["preview"] = str(render_video(panels, Path(out_dir) / f"{stem}_preview.mp4", CANONICAL.fps, size=size, progress=False))
    return info
