"""``video2style batch``: learn every video's style, apply each to every content clip; resumable."""
from __future__ import annotations

import html
import time
from dataclasses import dataclass, field
from pathlib import Path

from motioncore.bvh import atomic_write_text
from video2style.pipeline import VIDEO_SUFFIXES


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


def run_batch(videos_dir: Path, content_dir: Path, out_dir: Path, strength: float = 0.5, learn_config=None,
              seed: int = 0, progress=print) -> BatchReport:
    """Styles go to ``out/styles/<video>.v2s``; results to ``out/<video>/<clip>.bvh`` (+ previews)."""
    from transfer.style import Style, style_model
    from video2style.pipeline import apply_file, learn_file, load_models

    videos = find_videos(videos_dir)
    clips = sorted(Path(content_dir).rglob("*.bvh"))
    if not videos:
        raise FileNotFoundError(f"{videos_dir}: no videos ({', '.join(sorted(VIDEO_SUFFIXES))})")
    if not clips:
        raise FileNotFoundError(f"{content_dir}: no .bvh clips")
    report = BatchReport()
    for vi, video in enumerate(videos, 1):
        style_path = Path(out_dir) / "styles" / f"{video.stem}.v2s"
        t0 = time.time()
        if style_path.is_file():
            progress(f"[video {vi}/{len(videos)}] {video.name}: style exists, skipping learning")
        else:
            progress(f"[video {vi}/{len(videos)}] {video.name}: learning")
            try:
                learn_file(video, style_path, style_words=video.stem.replace("_", " "), config=learn_config,
                           progress=lambda s: progress(f"    {s}"))
            except Exception as e:  # noqa: BLE001 - one bad video must not stop the batch
                report.add(video=video.name, status="failed", error=f"learn: {e}", seconds=time.time() - t0)
                progress(f"    failed: {e}")
                continue
        style = Style.load(style_path)
        model = style_model(load_models().prior, style)
        for ci, clip in enumerate(clips, 1):
            out_bvh = Path(out_dir) / video.stem / f"{clip.stem}.bvh"
            if out_bvh.is_file():
                report.add(video=video.name, clip=clip.name, status="skipped (done)", output=str(out_bvh),
                           preview=str(out_bvh.with_name(f"{clip.stem}_preview.mp4")))
                continue
            t1 = time.time()
            try:
                info = apply_file(style, model, clip, out_bvh.parent, strength, seed)
            except Exception as e:  # noqa: BLE001 - one bad clip must not stop the batch
                report.add(video=video.name, clip=clip.name, status="failed", error=str(e), seconds=time.time() - t1)
                progress(f"    [{ci}/{len(clips)}] {clip.name}: failed: {e}")
                continue
            report.add(video=video.name, clip=clip.name, status="done", seconds=time.time() - t1,
                       output=info["output"], preview=info.get("preview", ""))
            progress(f"    [{ci}/{len(clips)}] {clip.name} -> {info['output']}")
    write_index(report, Path(out_dir))
    return report


def write_index(report: BatchReport, out_dir: Path) -> Path:
    """``out/index.html``: one row per video, one preview per clip."""
    cells: dict[str, list[str]] = {}
    for r in report.rows:
        if r.get("preview") and Path(r["preview"]).is_file():
            rel = Path(r["preview"]).resolve().relative_to(out_dir.resolve())
            cells.setdefault(r["video"], []).append(
                f'<figure><video src="{html.escape(str(rel))}" controls muted loop width="360"></video>'
                f"<figcaption><a href=\"{html.escape(str(rel))}\">{html.escape(r['clip'])}</a> "
                f"(content | style example | result)</figcaption></figure>")
        elif r["status"] == "failed":
            cells.setdefault(r["video"], []).append(
                f"<figure><figcaption>{html.escape(r.get('clip', 'learning'))}: failed: {html.escape(r['error'])}</figcaption></figure>")
    body = "".join(f"<h2>{html.escape(v)}</h2><div class=row>{''.join(c)}</div>" for v, c in cells.items())
    page = ("<!doctype html><meta charset=utf-8><title>video2style batch</title>"
            "<style>body{font-family:sans-serif}.row{display:flex;flex-wrap:wrap;gap:8px}figure{margin:0}</style>"
            "<h1>video2style batch results</h1><p>Previews are MPEG-4 part 2 (mp4v) files, which OpenCV writes "
            "without extra codecs; browsers that do not play them inline can open the links with VLC or any "
            "desktop player.</p>"
            f"{body}")
    path = out_dir / "index.html"
    atomic_write_text(path, page)
    return path
