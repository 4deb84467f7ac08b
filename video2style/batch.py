"""``video2style batch``: learn every video's style, apply each to every content clip; resumable."""
from __future__ import annotations

import fcntl
import html
import os
import re
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from motioncore.files import atomic_write_text
from video2style.pipeline import VIDEO_SUFFIXES, find_bvh_files


@dataclass
class BatchReport:
    rows: list[dict] = field(default_factory=list)  # one per (video, clip) or per failed video

    def add(self, **row) -> None:
        self.rows.append(row)

    @property
    def failures(self) -> list[dict]:
        return [r for r in self.rows if r["status"] == "failed"]

    def table(self) -> str:
        lines = ["| video | clip | status | seconds | output |", "|---|---|---|---|---|"]
        for r in self.rows:
            lines.append(f"| {r['video']} | {r.get('clip', '-')} | {r['status']}{': ' + r['error'] if r.get('error') else ''} "
                         f"| {r.get('seconds', 0):.1f} | {r.get('output', '')} |")
        return "\n".join(lines)


def find_videos(folder: Path) -> list[Path]:
    return sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in VIDEO_SUFFIXES)


def video_keys(videos: list[Path]) -> dict[Path, str]:
    """A name per video for its style file and result folder: the stem, or ``stem_ext`` where two videos
    share a stem (``x.mp4`` and ``x.mov``)."""
    stems = [v.stem for v in videos]
    return {v: v.stem if stems.count(v.stem) == 1 else f"{v.stem}_{v.suffix[1:].lower()}" for v in videos}


_TEMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}(\.tmp|\.mp4|\.avi)$")  # tempfile.mkstemp names our writers use


def sweep_temp_files(out_dir: Path) -> int:
    """Remove temporary files a killed run left behind (``.NAME.xxxxxxxx.mp4`` and the like); returns how many.
    Call only while holding the folder's lock: another run's files are then not in progress."""
    removed = 0
    for p in Path(out_dir).rglob(".*"):
        if p.is_file() and _TEMP.match(p.name):
            p.unlink(missing_ok=True)
            removed += 1
    return removed


@contextmanager
def folder_lock(out_dir: Path):
    """Hold ``out_dir/.video2style.lock`` for one batch at a time; a second batch on the folder gets one line."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / ".video2style.lock"
    with open(path, "a+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.seek(0)
            who = f.read().strip() or "another process"
            raise RuntimeError(f"{out_dir}: another batch is writing here ({who}); wait for it or use another -o") from None
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()}")
        f.flush()
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def plan(videos_dir: Path, content_dir: Path) -> tuple[list[Path], list[Path], dict[Path, str]]:
    """``(videos, clips, name of each video's style and result folder)``; FileNotFoundError when either is empty."""
    videos = find_videos(videos_dir)
    clips = find_bvh_files(content_dir)
    if not videos:
        raise FileNotFoundError(f"{videos_dir}: no videos ({', '.join(sorted(VIDEO_SUFFIXES))})")
    if not clips:
        raise FileNotFoundError(f"{content_dir}: no .bvh clips")
    return videos, clips, video_keys(videos)


@contextmanager
def batch_folder(out_dir: Path, progress):
    """Hold the output folder's lock; temporary files of killed runs are swept on entry and on leaving."""
    with folder_lock(out_dir):
        stale = sweep_temp_files(out_dir)
        if stale and progress is not None:
            progress(f"removed {stale} temporary file(s) left by an interrupted run")
        try:
            yield
        finally:
            sweep_temp_files(out_dir)  # a worker killed mid-write leaves its temporary file; all work is over now


def run_batch(videos_dir: Path, content_dir: Path, out_dir: Path, strength: float = 0.5, learn_config=None,
              seed: int = 0, progress=print, device: str = "cpu", rotate: int | None = None) -> BatchReport:
    """Styles go to ``out/styles/<video>.v2s``; results to ``out/<video>/<clip's path under content>.bvh``
    (+ previews). An item counts as done only when its BVH and its preview both exist; a style file in the
    output folder that does not load is learned again. One batch per output folder at a time. The models run
    on ``device`` (:func:`video2style.pipeline.load_models`). ``rotate``: every video's frames turned this many
    degrees clockwise before tracking (None: as they are; a video whose person is turned fails naming --rotate)."""
    out_dir = Path(out_dir)
    videos, clips, keys = plan(videos_dir, content_dir)
    with batch_folder(out_dir, progress):
        report = BatchReport()
        for vi, video in enumerate(videos, 1):
            _one_video(video, keys[video], f"[video {vi}/{len(videos)}]", clips, Path(content_dir), out_dir, strength,
                       learn_config, seed, progress, report, device, rotate)
        write_index(report, out_dir)
        write_report(report, out_dir)
    return report


def _style_for(video: Path, style_path: Path, tag: str, learn_config, progress, device: str = "cpu",
               rotate: int | None = None):
    """The video's style: loaded from the output folder if it is there and valid, else learned."""
    from transfer.style import Style
    from video2style.pipeline import learn_file

    if style_path.is_file():
        try:
            style = Style.load(style_path)
            progress(f"{tag} {video.name}: style exists, skipping learning")
            return style
        except ValueError as e:
            progress(f"{tag} {video.name}: {e}; learning it again")
    else:
        progress(f"{tag} {video.name}: learning")
    learn_file(video, style_path, style_words=video.stem.replace("_", " "), config=learn_config,
               progress=lambda s: progress(f"    {s}"), device=device, rotate=rotate)
    return Style.load(style_path)


def _one_video(video: Path, key: str, tag: str, clips: list[Path], content_dir: Path, out_dir: Path, strength: float,
               learn_config, seed: int, progress, report: BatchReport, device: str = "cpu",
               rotate: int | None = None) -> None:
    from transfer.style import style_model
    from video2style.pipeline import load_models

    t0 = time.time()
    try:
        style = _style_for(video, out_dir / "styles" / f"{key}.v2s", tag, learn_config, progress, device, rotate)
    except Exception as e:  # noqa: BLE001 - one bad video must not stop the batch
        report.add(video=video.name, status="failed", error=f"learn: {e}", seconds=time.time() - t0)
        progress(f"    failed: {e}")
        return
    model = style_model(load_models(device).prior, style)
    facts = _style_facts(style, strength)
    for ci, clip in enumerate(clips, 1):
        row = apply_item(style, model, facts, video.name, clip, out_dir / key / clip.relative_to(content_dir).parent,
                         strength, seed)
        report.add(**row)
        if row["status"] == "failed":
            progress(f"    [{ci}/{len(clips)}] {clip.name}: failed: {row['error']}")
        elif row["status"] == "done":
            progress(f"    [{ci}/{len(clips)}] {clip.name} -> {row['output']}")


def apply_item(style, model, facts: str, video: str, clip: Path, where: Path, strength: float, seed: int,
               retries: int = 0) -> dict:
    """One (video, clip) item of a batch into folder ``where`` (subfolders kept: no two clips collide): skipped
    when its BVH and preview exist, else applied (tried ``retries`` more times on an error). The report row."""
    from video2style.pipeline import apply_file

    out_bvh, preview = where / f"{clip.stem}.bvh", where / f"{clip.stem}_preview.mp4"
    player = where / f"{clip.stem}_player.js"
    row = {"video": video, "clip": clip.name, "content": str(clip), "style": facts, "output": str(out_bvh),
           "preview": str(preview), "player": str(player) if player.is_file() else ""}
    if out_bvh.is_file() and preview.is_file():
        return {**row, "status": "skipped (done)", "seconds": 0.0, "attempts": 0}
    t0, error = time.time(), None
    for attempt in range(1, retries + 2):
        try:
            info = apply_file(style, model, clip, where, strength, seed)
        except Exception as e:  # noqa: BLE001 - one bad clip must not stop the batch
            error = str(e)
            continue
        return {**row, "status": "done", "seconds": time.time() - t0, "attempts": attempt, "output": info["output"],
                "preview": info.get("preview", ""), "player": info.get("player", "")}
    return {**row, "status": "failed", "error": error, "seconds": time.time() - t0, "attempts": retries + 1,
            "output": "", "preview": "", "player": ""}  # a failed item wrote nothing (pipeline.write_outputs)


def _style_facts(style, strength: float) -> str:
    meta = getattr(style, "meta", {}) or {}
    facts = [f"style {meta.get('style', '?')!s}"]
    if meta.get("source"):
        facts.append(f"learned from {meta['source']}")
    if meta.get("iterations") is not None:
        facts.append(f"{meta['iterations']} iterations")
    return ", ".join(facts) + f"; applied at strength {strength:g}"


def write_report(report: BatchReport, out_dir: Path) -> Path:
    """``out/report.json``: one row per item (video, clip, status, seconds, output, error, ...)."""
    import json

    path = out_dir / "report.json"
    atomic_write_text(path, json.dumps(report.rows, indent=1, default=str) + "\n")
    return path


def write_index(report: BatchReport, out_dir: Path) -> Path:
    """``out/index.html``: per video, a player for each clip (content | style example | result, drawn in the
    page: no video codec needed) with links to the BVH files and the mp4 preview; failures listed."""
    from video2style.results_page import page, player_html

    def rel(p: str) -> str:  # a URL: a clip named "a#b?c%20.bvh" keeps its name
        from urllib.parse import quote

        path = Path(p).resolve()
        try:
            return quote(path.relative_to(out_dir.resolve()).as_posix())
        except ValueError:
            return path.as_uri()

    sections: dict[str, list[str]] = {}
    facts: dict[str, str] = {}
    for r in report.rows:
        figs = sections.setdefault(r["video"], [])
        if r["status"] == "failed":
            figs.append(f"<figure><figcaption>{html.escape(r.get('clip', 'learning'))}: failed: "
                        f"{html.escape(r['error'])}</figcaption></figure>")
            continue
        facts.setdefault(r["video"], r.get("style", ""))
        links = [(f"result {Path(r['output']).name}", rel(r["output"]))]
        if r.get("content"):
            links.append((f"content {Path(r['content']).name}", rel(r["content"])))
        if r.get("preview") and Path(r["preview"]).is_file():
            links.append(("mp4 preview", rel(r["preview"])))
        if r.get("player") and Path(r["player"]).is_file():
            figs.append(player_html(str(Path(r["player"]).resolve()), rel(r["player"]), r["clip"], links))
        else:
            figs.append("<figure><figcaption>" + " · ".join(
                f'<a href="{html.escape(h)}">{html.escape(t)}</a>' for t, h in links) + "</figcaption></figure>")
    text = page("video2style batch results", [(v, facts.get(v, ""), figs) for v, figs in sections.items()],
                "Each player shows the content clip, the style example and the result side by side: play, scrub "
                "with the slider, drag to turn the view. The mp4 previews are MPEG-4 part 2 files for desktop players.")
    path = out_dir / "index.html"
    atomic_write_text(path, text)
    return path
