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


STYLE_SUFFIX = ".v2s"


def is_style_file(path: Path) -> bool:
    return Path(path).suffix.lower() == STYLE_SUFFIX


def find_style_sources(inputs) -> list[Path]:
    """What a batch takes its styles from: each file named (a video, a BVH/FBX/GLB/glTF example, a ``.v2s`` style
    file from ``learn``, which is used as it is) and, in each folder named, its videos and style files (a folder's
    clips are left to ``--content``: name an example clip to learn from it). One-line errors otherwise."""
    from video2style.interchange import is_clip_file

    found: list[Path] = []
    for p in [inputs] if isinstance(inputs, (str, Path)) else inputs:
        p = Path(p)
        if p.is_dir():
            found += sorted(q for q in p.iterdir() if q.is_file() and (q.suffix.lower() in VIDEO_SUFFIXES or is_style_file(q)))
        elif not p.exists():
            raise FileNotFoundError(f"{p}: no such file or folder")
        elif p.suffix.lower() in VIDEO_SUFFIXES or is_style_file(p) or p.suffix.lower() == ".bvh" or is_clip_file(p):
            found.append(p)
        else:
            raise ValueError(f"{p}: not a video, a BVH/FBX/GLB/glTF example or a style file (.v2s)")
    return list(dict.fromkeys(found))


def style_path(source: Path, key: str, out_dir: Path) -> Path:
    """Where a source's style is: a style file given is used where it is; a learned one goes to ``OUT/styles``."""
    return Path(source) if is_style_file(source) else Path(out_dir) / "styles" / f"{key}.v2s"


def video_keys(videos: list[Path]) -> dict[Path, str]:
    """A name per style source (video, example clip, style file) for its style file and result folder: the stem,
    or ``stem_ext`` where two share a stem (``x.mp4`` and ``x.mov``) or where the stem is the style files' own folder
    (``styles.mp4``)."""
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


def plan(inputs, content_dir: Path, out_dir: Path | None = None,
         progress=None) -> tuple[list[Path], list[Path], dict[Path, str]]:
    """``(style sources, clips, name of each source's style and result folder)``: ``inputs`` a path or a list of
    them (:func:`find_style_sources`); FileNotFoundError when either is empty.
    With ``out_dir``, :func:`check_batch_outputs` first, and results are never taken as content
    (:func:`video2style.pipeline.content_clips`; ``progress`` hears what was left out)."""
    videos = find_style_sources(inputs)
    if not videos:
        names = ", ".join(str(p) for p in ([inputs] if isinstance(inputs, (str, Path)) else inputs))
        raise FileNotFoundError(f"{names}: no videos ({', '.join(sorted(VIDEO_SUFFIXES))}) nor style files (.v2s)")
    keys = video_keys(videos)
    if out_dir is not None:
        check_batch_outputs(inputs, content_dir, out_dir, list(keys.values()))
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


def check_batch_outputs(inputs, content_dir: Path, out_dir: Path, keys: list[str]) -> None:
    """Refuse, in one line, an output folder whose results would overwrite or mix with the inputs: ``-o`` the
    ``--content`` folder, or the content or style sources inside a result folder (``OUT/<video>``, ``OUT/styles``;
    a style file given may lie in ``OUT/styles``: it is only read); and a result folder that is a symlink
    (someone sharing OUT could point it at the user's files)."""
    out_dir = Path(out_dir)
    sources = [Path(p) for p in ([inputs] if isinstance(inputs, (str, Path)) else inputs)]
    check_outputs([("-o", out_dir)], [("the --content folder", content_dir)])
    check_no_links(out_dir, [out_dir / sub for sub in ["styles", *keys]])
    for sub in ["styles", *keys]:
        where = out_dir / sub
        named = [("the --content folder", content_dir)] + [("the videos folder" if p.is_dir() else "the style source", p)
                                                           for p in sources if not (sub == "styles" and is_style_file(p))]
        for what, folder in named:
            if inside(folder, where):
                raise ValueError(f"{where}: -o would write results into {what} {folder} "
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


def run_batch(inputs, content_dir: Path, out_dir: Path, strength: float = 0.5, learn_config=None,
              seed: int = 0, progress=print, device: str = "cpu", rotate: int | None = None,
              options=None) -> BatchReport:
    """Styles from ``inputs`` (:func:`find_style_sources`: videos, example clips, style files, folders of videos and
    style files): a style file is used as it is; every other source's style is learned into ``out/styles/<name>.v2s``
    (and loaded from there on a later run). Results go to ``out/<name>/<clip's path under content>`` (+ previews).
    ``options``: the apply options (:class:`video2style.options.ApplyOptions`; default: ``strength`` and ``seed``,
    the rest as apply's defaults). An item counts as done only when its result and its preview both exist; a style
    file in the output folder that does not load is learned again. One batch per output folder at a time. The models
    run on ``device`` (:func:`transfer.bundle.load_models`). ``rotate``: every video's frames turned this many
    degrees clockwise before tracking (None: as they are; a video whose person is turned fails naming --rotate)."""
    from video2style.options import ApplyOptions

    options = options or ApplyOptions(strength=strength, seed=seed)
    out_dir = Path(out_dir)
    videos, clips, keys = plan(inputs, content_dir, out_dir, progress)
    with batch_folder(out_dir, progress):
        report = BatchReport()
        for vi, video in enumerate(videos, 1):
            _one_video(video, keys[video], f"[style {vi}/{len(videos)}]", clips, Path(content_dir), out_dir, options,
                       learn_config, progress, report, device, rotate)
        write_index(report, out_dir)
        write_report(report, out_dir)
    return report


def _style_for(video: Path, style_file: Path, tag: str, learn_config, progress, device: str = "cpu",
               rotate: int | None = None):
    """The source's style: a style file given, loaded; else loaded from the output folder if it is there and
    valid, else learned (an FBX/glTF example through its action as BVH)."""
    from transfer.style_file import Style
    from video2style.interchange import is_clip_file, shared_converter
    from video2style.pipeline import learn_file

    if is_style_file(video):
        style = Style.load(video)
        progress(f"{tag} {video.name}: a style file, used as it is")
        return style
    if style_file.is_file():
        try:
            style = Style.load(style_file)
            progress(f"{tag} {video.name}: style exists, skipping learning")
            return style
        except ValueError as e:
            progress(f"{tag} {video.name}: {e}; learning it again")
    else:
        progress(f"{tag} {video.name}: learning")
    is_video = video.suffix.lower() in VIDEO_SUFFIXES
    source = shared_converter().to_bvh(video) if is_clip_file(video) else video
    learn_file(source, style_file, style_words=video.stem.replace("_", " "), config=learn_config,
               progress=lambda s: progress(f"    {s}"), device=device, rotate=rotate if is_video else None)
    return Style.load(style_file)


def _one_video(video: Path, key: str, tag: str, clips: list[Path], content_dir: Path, out_dir: Path, options,
               learn_config, progress, report: BatchReport, device: str = "cpu",
               rotate: int | None = None) -> None:
    from transfer.bundle import load_models
    from transfer.style_file import style_model

    t0 = time.time()
    try:
        style = _style_for(video, style_path(video, key, out_dir), tag, learn_config, progress, device, rotate)
    except Exception as e:  # noqa: BLE001 - one bad video must not stop the batch
        report.add(video=video.name, status="failed",
                   error=f"{'style' if is_style_file(video) else 'learn'}: {printable(e)}", seconds=time.time() - t0)
        progress(f"    failed: {printable(e)}")
        return
    model = style_model(load_models(device).prior, style)
    facts = _style_facts(style, options.strength)
    for ci, clip in enumerate(clips, 1):
        row = apply_item(style, model, facts, video.name, clip, out_dir / key / clip.relative_to(content_dir).parent,
                         options)
        report.add(**row)
        if row["status"] == "failed":
            progress(f"    [{ci}/{len(clips)}] {clip.name}: failed: {row['error']}")
        elif row["status"] == "done":
            progress(f"    [{ci}/{len(clips)}] {clip.name} -> {row['output']}: {row['summary']}")


_CONVERTERS: dict = {}


def _converter(options):
    """This process's :class:`video2style.interchange.Converter` for ``options``' --armature/--action (one Blender)."""
    from video2style.interchange import Converter, shared_converter

    if options.armature is None and options.action is None:
        return shared_converter()
    key = (options.armature, options.action)
    if key not in _CONVERTERS:
        import sys

        _CONVERTERS[key] = Converter(*key, notify=lambda s: print(s, file=sys.stderr))
    return _CONVERTERS[key]


def apply_item(style, model, facts: str, video: str, clip: Path, where: Path, options, retries: int = 0) -> dict:
    """One (video, clip) item of a batch into folder ``where`` (subfolders kept: no two clips collide), with the
    apply ``options`` (:class:`video2style.options.ApplyOptions`): skipped when its result and preview (when one is
    asked for) exist, else applied (tried ``retries`` more times on an error). The report row."""
    from motioncore.retarget import load_joint_map
    from video2style.interchange import in_format, output_suffix
    from video2style.pipeline import apply_file
    from video2style.summary import clip_details

    joint_map = load_joint_map(options.joint_map) if options.joint_map else None

    def one(path, folder):
        return apply_file(style, model, path, folder, options.strength, options.seed, options.neutralize, joint_map,
                          options.preview, options.tempo, options.feet)

    # an FBX/glTF clip's result: the same format (or --format), keyed onto its own file (one Blender per process)
    run = in_format(one, lambda: _converter(options), options.format)
    out_bvh = where / f"{clip.stem}{output_suffix(clip, options.format)}"
    preview = where / f"{clip.stem}_preview.mp4"
    player = where / f"{clip.stem}_player.js"
    row = {"video": video, "clip": clip.name, "content": str(clip), "style": facts, "output": str(out_bvh),
           "preview": str(preview) if options.preview else "", "player": str(player) if player.is_file() else ""}
    if out_bvh.is_file() and (preview.is_file() or not options.preview):
        return {**row, "status": "skipped (done)", "seconds": 0.0, "attempts": 0}
    t0, error = time.time(), None
    for attempt in range(1, retries + 2):
        try:
            info = run(clip, where)
        except Exception as e:  # noqa: BLE001 - one bad clip must not stop the batch
            error = printable(e)  # one line, nothing a crafted file or Blender said can reach the terminal raw
            continue
        details = {k: v for k, v in clip_details(info).items() if k not in ("input", "output", "preview", "player", "seconds")}
        return {**row, "status": "done", "seconds": time.time() - t0, "attempts": attempt, "output": info["output"],
                "preview": info.get("preview", ""), "player": info.get("player", ""), **details}
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


def write_index(report: BatchReport, out_dir: Path, title: str = "video2style batch results") -> Path:
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
        caption = r["clip"] + "".join(f"; {note}" for note in r.get("notes", [])) + (
            f" — {r['summary']}" if r.get("summary") else "")
        if r.get("player") and Path(r["player"]).is_file():
            figs.append(player_html(str(Path(r["player"]).resolve()), rel(r["player"]), caption, links))
        else:
            figs.append(f"<figure><figcaption>{html.escape(caption)}<br>" + " · ".join(
                f'<a href="{html.escape(h)}">{html.escape(t)}</a>' for t, h in links) + "</figcaption></figure>")
    text = page(title, [(v, facts.get(v, ""), figs) for v, figs in sections.items()],
                "Each player shows the content clip, the style example and the result side by side: play, scrub "
                "with the slider, drag to turn the view. The mp4 previews are MPEG-4 part 2 files for desktop players.")
    path = out_dir / "index.html"
    atomic_write_text(path, text)
    return path
