"""``video2style batch``: learn every video's style, apply each to every content clip; resumable."""
from __future__ import annotations

import errno
import fcntl
import html
import os
import stat
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from motioncore.files import atomic_write_text, is_temp_name
from motioncore.text import printable
from video2style.paths import LOCK_NAME, check_no_links, check_outputs, inside
from video2style.pipeline import VIDEO_SUFFIXES, content_clips


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
    share a stem (``x.mp4`` and ``x.mov``) or where the stem is the style files' own folder (``styles.mp4``)."""
    stems = [v.stem for v in videos]
    return {v: v.stem if stems.count(v.stem) == 1 and v.stem.lower() != "styles" else f"{v.stem}_{v.suffix[1:].lower()}"
            for v in videos}


def sweep_temp_files(out_dir: Path, recursive: bool = True) -> int:
    """Remove temporary files a killed run left behind in ``out_dir`` (its subfolders too, unless ``recursive`` is
    False); returns how many. Only files of our own making go (:func:`motioncore.files.is_temp_name`: a user's
    ``.notes.20241201.tmp`` stays), never through a symlink. Call only while holding the folder's lock: another
    run's files are then not in progress."""
    removed = 0
    for p in Path(out_dir).rglob(".*") if recursive else Path(out_dir).glob(".*"):
        if is_temp_name(p.name) and not p.is_symlink() and p.is_file():
            p.unlink(missing_ok=True)
            removed += 1
    return removed


def _open_lock(path: Path) -> int:
    """The lock file's descriptor, opened without following a symlink (one planted there must not make us write
    to its target) and only when it is a regular file; a one-line RuntimeError otherwise."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK, 0o644)
    except OSError as e:
        if e.errno == errno.ELOOP:
            raise RuntimeError(f"{path}: is a symbolic link, not our lock file; not following it (remove it if "
                               "you did not make it)") from None
        raise
    problem = _not_our_lock(os.fstat(fd))
    if problem:
        os.close(fd)
        raise RuntimeError(f"{path}: {problem}, so it cannot be our lock file; not writing it (remove it if you did "
                           "not make it, or use another -o)")
    return fd


def _not_our_lock(st: os.stat_result) -> str | None:
    """Why an open lock file cannot be one of ours (None when it can): not a regular file, a hard link to a file
    elsewhere (writing the pid line would truncate that file), or another user's file."""
    if not stat.S_ISREG(st.st_mode):
        return "is not a regular file"
    if st.st_nlink != 1:
        return f"has {st.st_nlink} hard links (a file elsewhere shares it)"
    if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
        return f"belongs to another user (uid {st.st_uid})"
    return None


def _held(folder: Path) -> str | None:
    """``"pid N apply"`` when another run holds ``folder``'s lock now, else None (no lock file, or a link: not ours)."""
    try:
        fd = os.open(folder / LOCK_NAME, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK)
    except OSError:
        return None
    with os.fdopen(fd) as f:
        try:
            fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return _holder(f)
        except OSError:  # not a file flock works on: not a lock of ours
            return None
        fcntl.flock(f, fcntl.LOCK_UN)
    return None


def _holder(f) -> str:
    """The holder's line from an open lock file (``pid N batch``), printable characters only: a shared folder's
    lock file is anyone's to write."""
    f.seek(0)
    text = "".join(ch for ch in f.read(200) if ch.isprintable())
    return " ".join(text.split()) or "another process"


def _busy_error(out_dir: Path, where: Path, who: str) -> RuntimeError:
    words = who.split()
    held_by = words[2] if len(words) > 2 and words[2] in ("batch", "apply") else "run"
    here = "here" if where == out_dir else f"in {where}"
    return RuntimeError(f"{out_dir}: another {held_by} is writing {here} ({' '.join(words[:2])}); "
                        "wait for it or use another -o")


@contextmanager
def folder_lock(out_dir: Path, command: str = "batch", writes_into=()):
    """Hold ``out_dir/.video2style.lock`` for one run at a time (``command``: batch or apply, said to a second run,
    which gets one line). The lock file is never followed through a symlink (:func:`_open_lock`). A run into a
    folder above (holding ``out_dir``) or below (one of ``writes_into``, the folders this run writes below
    ``out_dir``) is refused the same way: each run takes its own lock first, then looks at the others'."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / LOCK_NAME
    fd = _open_lock(path)
    with os.fdopen(fd, "r+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise _busy_error(out_dir, out_dir, _holder(f)) from None
        try:
            below = {q for w in writes_into for q in [Path(w), *Path(w).parents] if out_dir in q.parents}
            for other in [*Path(os.path.realpath(out_dir)).parents, *sorted(below)]:
                who = _held(other)
                if who is not None:
                    raise _busy_error(out_dir, other, who)
            f.seek(0)
            f.truncate()
            f.write(f"pid {os.getpid()} {command}")
            f.flush()
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def plan(videos_dir: Path, content_dir: Path, out_dir: Path | None = None,
         progress=None) -> tuple[list[Path], list[Path], dict[Path, str]]:
    """``(videos, clips, name of each video's style and result folder)``; FileNotFoundError when either is empty.
    With ``out_dir``, :func:`check_batch_outputs` first, and results are never taken as content
    (:func:`video2style.pipeline.content_clips`; ``progress`` hears what was left out)."""
    videos = find_videos(videos_dir)
    if not videos:
        raise FileNotFoundError(f"{videos_dir}: no videos ({', '.join(sorted(VIDEO_SUFFIXES))})")
    keys = video_keys(videos)
    if out_dir is not None:
        check_batch_outputs(videos_dir, content_dir, out_dir, list(keys.values()))
    from video2style.interchange import find_clip_files, result_suffixes

    protected: list[Path] = []
    clips = sorted(content_clips(content_dir, out_dir, progress, protected=protected)
                   + find_clip_files(content_dir, out_dir, protected=protected))
    if not clips:
        raise FileNotFoundError(f"{content_dir}: no .bvh clips (nor .fbx, .glb, .gltf)")
    if out_dir is not None:  # and no folder a result goes to is reached through a link planted in -o
        check_no_links(out_dir, {out_dir / key / c.relative_to(content_dir).parent for key in keys.values() for c in clips})
    if protected:  # the user's clips inside -o: no result may land on one
        check_outputs([("-o", out_dir / key / c.relative_to(content_dir).parent / f"{c.stem}{end}") for key in keys.values()
                       for c in clips for end in (*result_suffixes(c), "_preview.mp4", "_player.js")],
                      [("a clip in the --content folder", c) for c in protected])
    return videos, clips, keys


def check_batch_outputs(videos_dir: Path, content_dir: Path, out_dir: Path, keys: list[str]) -> None:
    """Refuse, in one line, an output folder whose results would overwrite or mix with the inputs: ``-o`` the
    ``--content`` folder, or the content or videos inside a result folder (``OUT/<video>``, ``OUT/styles``); and
    a result folder that is a symlink (someone sharing OUT could point it at the user's files)."""
    out_dir = Path(out_dir)
    check_outputs([("-o", out_dir)], [("the --content folder", content_dir)])
    check_no_links(out_dir, [out_dir / sub for sub in ["styles", *keys]])
    for sub in ["styles", *keys]:
        where = out_dir / sub
        for what, folder in (("--content", content_dir), ("videos", videos_dir)):
            if inside(folder, where):
                raise ValueError(f"{where}: -o would write results into the {what} folder {folder} "
                                 "(results would overwrite or mix with the inputs); give another -o")


@contextmanager
def batch_folder(out_dir: Path, progress):
    """Hold the output folder's lock (:func:`folder_lock`); temporary files of killed runs are swept on entry and on
    leaving."""
    nested = [lock.parent for lock in out_dir.rglob(LOCK_NAME) if lock.parent != out_dir] if out_dir.is_dir() else []
    with folder_lock(out_dir, "batch", nested):  # the sweep below must not meet another run's files in progress
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
    on ``device`` (:func:`transfer.bundle.load_models`). ``rotate``: every video's frames turned this many
    degrees clockwise before tracking (None: as they are; a video whose person is turned fails naming --rotate)."""
    out_dir = Path(out_dir)
    videos, clips, keys = plan(videos_dir, content_dir, out_dir, progress)
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
    from transfer.style_file import Style
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
    from transfer.bundle import load_models
    from transfer.style_file import style_model

    t0 = time.time()
    try:
        style = _style_for(video, out_dir / "styles" / f"{key}.v2s", tag, learn_config, progress, device, rotate)
    except Exception as e:  # noqa: BLE001 - one bad video must not stop the batch
        report.add(video=video.name, status="failed", error=f"learn: {printable(e)}", seconds=time.time() - t0)
        progress(f"    failed: {printable(e)}")
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
    from video2style.interchange import in_format, is_clip_file, shared_converter
    from video2style.pipeline import apply_file, apply_notes

    # an FBX/glTF clip's result: the same format, keyed onto its own file (one Blender per batch process)
    run = in_format(lambda path, folder: apply_file(style, model, path, folder, strength, seed), shared_converter)
    out_bvh = where / f"{clip.stem}{clip.suffix.lower() if is_clip_file(clip) else '.bvh'}"
    preview = where / f"{clip.stem}_preview.mp4"
    player = where / f"{clip.stem}_player.js"
    row = {"video": video, "clip": clip.name, "content": str(clip), "style": facts, "output": str(out_bvh),
           "preview": str(preview), "player": str(player) if player.is_file() else ""}
    if out_bvh.is_file() and preview.is_file():
        return {**row, "status": "skipped (done)", "seconds": 0.0, "attempts": 0}
    t0, error = time.time(), None
    for attempt in range(1, retries + 2):
        try:
            info = run(clip, where)
        except Exception as e:  # noqa: BLE001 - one bad clip must not stop the batch
            error = printable(e)  # one line, nothing a crafted file or Blender said can reach the terminal raw
            continue
        return {**row, "status": "done", "seconds": time.time() - t0, "attempts": attempt, "output": info["output"],
                "preview": info.get("preview", ""), "player": info.get("player", ""), "notes": apply_notes(info)}
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
        caption = r["clip"] + "".join(f"; {note}" for note in r.get("notes", []))
        if r.get("player") and Path(r["player"]).is_file():
            figs.append(player_html(str(Path(r["player"]).resolve()), rel(r["player"]), caption, links))
        else:
            figs.append(f"<figure><figcaption>{html.escape(caption)}<br>" + " · ".join(
                f'<a href="{html.escape(h)}">{html.escape(t)}</a>' for t, h in links) + "</figcaption></figure>")
    text = page("video2style batch results", [(v, facts.get(v, ""), figs) for v, figs in sections.items()],
                "Each player shows the content clip, the style example and the result side by side: play, scrub "
                "with the slider, drag to turn the view. The mp4 previews are MPEG-4 part 2 files for desktop players.")
    path = out_dir / "index.html"
    atomic_write_text(path, text)
    return path
