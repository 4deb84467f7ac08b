"""FBX and glTF clips in and out, through Blender's own importers and exporters; the rest of video2style stays BVH.

One Blender process (``blender -b`` on PATH, or a Python with the ``bpy`` module from ``pip install
"video2style[fbx]"``) serves a whole command: :class:`Converter` starts it on the first FBX/glTF file and
feeds it jobs (:mod:`video2style.blender_io`, the script it runs). Reading a clip writes its armature's
action as BVH in the armature's own axes and units; writing a result keys the styled joints back onto the
ORIGINAL file's armature (so a skinned mesh keeps its mesh, materials and weights, bones keep names, rest
pose and roll) and exports it in the file's format, atomically.
"""
from __future__ import annotations

import contextlib
import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from pathlib import Path

import numpy as np

from motioncore.text import printable

CLIP_SUFFIXES = {".fbx", ".glb", ".gltf"}
MAX_CLIP_SECONDS = 6 * 3600.0  # as video2style.pipeline's: a longer action is refused before Blender exports it
FORMATS = ("bvh", "fbx", "glb", "gltf")
SCRIPT = Path(__file__).with_name("blender_io.py")
HOW_TO_GET = ('pip install "video2style[fbx]" (the bpy module, Python 3.11) or install Blender 3.4+ with numpy '
              "in its Python so that `blender` is on PATH (Debian/Ubuntu: apt install blender python3-numpy)")


class InterchangeError(ValueError):
    """An FBX/glTF file that cannot be read or written: one line naming it."""


def is_clip_file(path: str | os.PathLike) -> bool:
    """True for an FBX or glTF/GLB file (by its suffix, any case)."""
    return Path(path).suffix.lower() in CLIP_SUFFIXES


def output_suffix(path: str | os.PathLike, fmt: str | None) -> str:
    """The suffix a result of clip ``path`` gets: ``fmt`` ("bvh", "fbx", "glb", "gltf") or, when None, the input's own."""
    if fmt is None:
        return Path(path).suffix.lower()
    if fmt not in FORMATS:
        raise ValueError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    return f".{fmt}"


GLTF_JSON_BYTES = 64 << 20  # a glTF's JSON part larger than this is not looked into (nor read by us)


def gltf_json(path: str | os.PathLike) -> dict | None:
    """The JSON part of a ``.gltf`` (the whole file) or ``.glb`` (its first chunk); None for other files and for
    one too damaged to parse (Blender's importer then says what is wrong)."""
    import struct

    path = Path(path)
    suffix = path.suffix.lower()
    try:
        with open(path, "rb") as f:
            if suffix == ".gltf":
                raw = f.read(GLTF_JSON_BYTES + 1)
            elif suffix == ".glb":
                head = f.read(20)
                if len(head) < 20 or head[:4] != b"glTF":
                    return None
                length, kind = struct.unpack("<II", head[12:20])
                if kind != 0x4E4F534A or length > GLTF_JSON_BYTES:  # "JSON"
                    return None
                raw = f.read(length)
            else:
                return None
        if len(raw) > GLTF_JSON_BYTES:
            return None
        doc = json.loads(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None
    return doc if isinstance(doc, dict) else None


def outside_resources(path: str | os.PathLike) -> list[str]:
    """The URIs of a glTF/GLB's external resources (images, buffers) that are not files inside the file's own
    folder: absolute paths, other schemes (``file:``, ``http:``), ``..`` out of the folder or a symlink leading
    out. Embedded ``data:`` URIs are fine."""
    from urllib.parse import unquote, urlsplit

    from video2style.paths import inside

    doc = gltf_json(path)
    if doc is None:
        return []
    folder = Path(path).resolve().parent
    bad = []
    for kind in ("images", "buffers"):
        items = doc.get(kind)
        for item in items if isinstance(items, list) else []:
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            parts = urlsplit(uri)
            rel = unquote(parts.path)
            if parts.scheme or parts.netloc or os.path.isabs(rel) or "\\" in rel or not inside(folder / rel, folder):
                bad.append(uri)
    return bad


def check_resources(path: str | os.PathLike) -> None:
    """Refuse, in one line, a glTF/GLB whose images or buffers lie outside its own folder (a crafted file could
    have the user's other files read and embedded in a result)."""
    bad = outside_resources(path)
    if bad:
        raise InterchangeError(f"{path}: refers to {printable(repr(bad[0]), 200)} outside the file's folder"
                               f"{f' (and {len(bad) - 1} more)' if len(bad) > 1 else ''}; resources outside it are "
                               "not read")


def blender_command() -> list[str] | None:
    """How to run the Blender-side script: the Blender that ``$VIDEO2STYLE_BLENDER`` names where it is set (so it
    chooses even where this Python has ``bpy``), else the ``bpy`` module in this Python, else ``blender`` on PATH;
    None when none of these is there."""
    named = os.environ.get("VIDEO2STYLE_BLENDER", "").strip()
    if not named and importlib.util.find_spec("bpy") is not None:
        return [sys.executable, str(SCRIPT)]
    exe = shutil.which(named or "blender")
    if exe is None:
        return None
    return [exe, "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(SCRIPT)]


def blender_env() -> dict[str, str]:
    """The environment for ``blender``: PATH without this Python's own folders (a pyenv or virtualenv
    ``python3.11`` found first on PATH becomes the embedded Python's home, which lacks Blender's numpy)."""
    ours = {Path(p).resolve() for p in (sys.prefix, sys.base_prefix)} - {Path("/usr"), Path("/usr/local"), Path("/")}
    env = {k: v for k, v in os.environ.items() if k != "VIRTUAL_ENV"}
    keep = [d for d in env.get("PATH", "").split(os.pathsep)
            if d and not any(Path(d).resolve() == o or o in Path(d).resolve().parents for o in ours)]
    env["PATH"] = os.pathsep.join(keep)
    return env


STARTUP_TIMEOUT_S = 120.0  # Blender says it is ready (its script started) within this, or it is ended
JOB_TIMEOUT_S = 120.0  # the least a file's read or write may take; each job gets more for its size (job_limit)
READ_S_PER_MB = 30.0  # a read: this much more per MB of the file
WRITE_S_PER_FRAME = 0.01  # a write: this much more per frame of the clip
MAX_ANSWER_BYTES = 4 << 20  # an answer line longer than this is not an answer; other output is read and dropped
TAIL_BYTES = 64 << 10  # of Blender's own output, the last this much is kept for an error message
SHOWN_CHARS = 300  # of what Blender said, at most this much goes into a one-line error
QUIET_S = 2.0  # an answer without its newline counts once Blender has been silent this long
READY = "V2S-READY"
RESULT = "V2S-RESULT "
REQUIRED = {"read": ("armature", "action", "fps", "frame_start", "frame_end"), "write": ()}


def job_limit(job: dict, frames: int | None = None) -> float:
    """Seconds one job may take: :data:`JOB_TIMEOUT_S`, plus per MB of the file read or per frame written."""
    if job.get("op") == "read":
        try:
            size = os.path.getsize(job["path"])
        except (OSError, KeyError, TypeError):
            size = 0
        return JOB_TIMEOUT_S + READ_S_PER_MB * size / 1e6
    return JOB_TIMEOUT_S + WRITE_S_PER_FRAME * (frames or 0)


def parse_answer(text: str, op: str | None = None) -> dict:
    """Blender's answer line (after ``V2S-RESULT``) as a dict with ``ok`` and, when ok, the fields ``op`` needs
    (:data:`REQUIRED`); ValueError (a short reason) for anything else, TypeError (as short) for JSON that is not
    an object with a boolean ``ok``."""
    try:
        out = json.loads(text)
    except (ValueError, RecursionError):
        raise ValueError("an answer that is not JSON") from None
    if not isinstance(out, dict) or not isinstance(out.get("ok"), bool):
        raise TypeError("an answer without its ok field")
    if not out["ok"]:
        if not isinstance(out.get("error"), str) or not out["error"].strip():
            raise ValueError("a failure without its error")
        return out
    missing = [k for k in REQUIRED.get(op, ()) if k not in out]
    if missing:
        raise ValueError(f"an answer without {', '.join(missing)}")
    if op == "read" and not all(isinstance(out[k], (int, float)) and not isinstance(out[k], bool) and
                                math.isfinite(out[k]) for k in ("fps", "frame_start", "frame_end")):
        raise ValueError("an answer with a frame range or rate that is not a number")
    if op == "read" and not out["fps"] > 0:
        raise ValueError("an answer with a rate that is not positive")
    return out


class _Tail:
    """The last :data:`TAIL_BYTES` of a stream, drained by a thread (a child writing 400 MB costs no memory)."""

    def __init__(self, stream=None):
        self.data = bytearray()
        self.lock = threading.Lock()
        if stream is not None:
            threading.Thread(target=self._drain, args=(stream,), daemon=True).start()

    def _drain(self, stream) -> None:
        try:
            for chunk in iter(lambda: stream.read1(65536), b""):
                self.add(chunk)
        except (OSError, ValueError):
            pass

    def add(self, chunk: bytes) -> None:
        with self.lock:
            self.data += chunk
            del self.data[:-TAIL_BYTES]

    def lines(self) -> list[str]:
        with self.lock:
            return [ln for ln in bytes(self.data).decode("utf-8", "replace").splitlines() if ln.strip()]


class Blender:
    """One headless Blender process answering jobs (see :mod:`video2style.blender_io`). Started on the
    first :meth:`call`; :meth:`close` (or leaving a ``with`` block) ends it. Blender must say it is ready within
    ``startup`` seconds (default: :data:`STARTUP_TIMEOUT_S`, or ``timeout`` where shorter), and answer each job within its limit (``timeout``, else :func:`job_limit`); else the
    process is ended and :class:`InterchangeError` raised. What it prints is read in bounded pieces."""

    def __init__(self, timeout: float | None = None, startup: float | None = None):
        self._proc: subprocess.Popen | None = None
        self._err: _Tail | None = None
        self._out: _Tail | None = None
        self._buf = bytearray()
        self._ready = False
        self.timeout = timeout
        self.startup = startup if startup is not None else min(STARTUP_TIMEOUT_S, timeout or STARTUP_TIMEOUT_S)

    def _start(self, path: Path) -> None:
        cmd = blender_command()
        if cmd is None:
            named = os.environ.get("VIDEO2STYLE_BLENDER", "").strip()
            if named:
                raise InterchangeError(f"{path}: $VIDEO2STYLE_BLENDER names {printable(repr(named), 200)}, which is not "
                                       "an executable (unset it to use the bpy module or `blender` on PATH)")
            raise InterchangeError(f"{path}: reading and writing FBX/glTF needs Blender: {HOW_TO_GET}")
        env = None if cmd[0] == sys.executable else blender_env()
        try:
            self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                          env=env, start_new_session=True)  # Ctrl-C reaches us; we end it
        except OSError as e:
            raise InterchangeError(f"{path}: Blender could not be started ({printable(e.strerror or e)})") from None
        self._err, self._out = _Tail(self._proc.stderr), _Tail()
        self._buf, self._ready = bytearray(), False

    def call(self, job: dict, path: Path, limit: float | None = None, name: str | None = None) -> dict:
        """Run one job; its answer, or :class:`InterchangeError` naming ``path`` (``name`` where given: the file
        a user knows). ``limit``: the seconds it may take (default ``timeout`` or :func:`job_limit`)."""
        shown = name or str(path)
        if self._proc is None:
            self._start(Path(shown))
        try:
            if not self._ready:
                if self._wait(self.startup, shown, ready=True) is None:
                    return self._fail(shown, f"Blender gave no answer within {self.startup:g} s of starting and was stopped")
                self._ready = True
            try:
                self._proc.stdin.write((json.dumps(job) + "\n").encode())
                self._proc.stdin.flush()
            except (BrokenPipeError, OSError):
                return self._fail(shown, "Blender ended early")
            seconds = limit if limit is not None else self.timeout if self.timeout is not None else job_limit(job)
            line = self._wait(seconds, shown)
            if line is None:
                return self._fail(shown, f"Blender gave no answer within {seconds:g} s and was stopped")
        except BaseException:  # Ctrl-C, SIGTERM, an error: a Blender mid-job is ended now, not waited for
            self.kill()
            raise
        try:
            out = parse_answer(line, job.get("op"))
        except (TypeError, ValueError) as e:
            self.kill()  # a Blender that answers nonsense is not asked again
            raise InterchangeError(f"{shown}: Blender gave {e}: {printable(line, SHOWN_CHARS) or 'nothing'}") from None
        if not out.pop("ok"):
            error = out["error"]
            for key in ("path", "source"):  # the file as the user named it, once
                if isinstance(job.get(key), str) and job[key]:
                    error = error.replace(f"{job[key]}: ", "").replace(job[key], shown)
            error = printable(error, 2 * SHOWN_CHARS)  # one line, printable, whatever Blender said
            raise InterchangeError(error if error.startswith(shown) else f"{shown}: {error}")
        return out

    def _wait(self, seconds: float, shown: str, ready: bool = False) -> str | None:
        """Read Blender's output until its ready line (``ready``) or answer line; the line's text after the mark
        ("" for ready), or None when ``seconds`` pass or Blender ends first (then the process is ended)."""
        import select

        proc, deadline = self._proc, time.monotonic() + seconds
        fd = proc.stdout.fileno()
        quiet_since = None
        while True:
            line = self._next_line(ready, final=False)
            if line is not None:
                return line
            now = time.monotonic()
            if now >= deadline:
                return None
            wait = deadline - now
            if self._buf.startswith(RESULT.encode()):  # an answer cut short of its newline (a full disk)
                quiet_since = quiet_since or now
                if now - quiet_since >= QUIET_S:
                    return self._next_line(ready, final=True)
                wait = min(wait, QUIET_S)
            readable, _, _ = select.select([fd], [], [], wait)
            if not readable:
                continue
            chunk = os.read(fd, 1 << 16)
            if not chunk:  # Blender ended
                return self._next_line(ready, final=True)
            quiet_since = None
            self._buf += chunk

    def _next_line(self, ready: bool, final: bool) -> str | None:
        """The next ready or answer line in what was read (``final``: the rest counts as a line); other lines
        go to the kept tail. Output past :data:`MAX_ANSWER_BYTES` without a newline is dropped."""
        while True:
            cut = self._buf.find(b"\n")
            if cut < 0:
                if len(self._buf) > MAX_ANSWER_BYTES:
                    self._out.add(b"[" + bytes(self._buf[-200:]) + b"]\n")
                    self._buf = bytearray(b"[dropped]")
                    return None
                if not final or not self._buf:
                    return None
                cut = len(self._buf)
            raw, self._buf = bytes(self._buf[:cut]), self._buf[cut + 1:]
            text = raw.decode("utf-8", "replace").rstrip("\r")
            if ready and text.strip() == READY:
                return ""
            if text.startswith(RESULT):
                return text[len(RESULT):]
            if text.strip() != READY:
                self._out.add(raw[-TAIL_BYTES:] + b"\n")

    def _fail(self, shown: str, what: str):
        tail = self._tail()
        self.kill()
        raise InterchangeError(f"{shown}: {what}: {tail}" if tail else f"{shown}: {what}")

    def _tail(self) -> str:
        lines = (self._out.lines() if self._out else []) + (self._err.lines() if self._err else [])
        if any("numpy" in ln for ln in lines):
            return f"Blender's Python lacks numpy (its FBX/glTF add-ons need it): {HOW_TO_GET}"
        return printable(lines[-1], SHOWN_CHARS) if lines else "no output"

    def kill(self) -> None:
        """End the process now (it may be mid-job)."""
        if self._proc is not None:
            with contextlib.suppress(OSError):
                self._proc.kill()
            self._proc.wait()
            self._closed()

    def _closed(self) -> None:
        for stream in (self._proc.stdin, self._proc.stdout, self._proc.stderr):
            with contextlib.suppress(OSError):
                stream.close()
        self._proc = None
        self._ready = False

    def close(self) -> None:
        """Ask Blender to end (its input closed), a few seconds' grace, then end it."""
        if self._proc is not None:
            try:
                self._proc.stdin.close()
                self._proc.wait(timeout=5)
                self._closed()
            except (OSError, subprocess.TimeoutExpired):
                self.kill()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def motion_arrays(bvh: str | os.PathLike) -> dict[str, np.ndarray]:
    """A BVH file's joints as global transforms in the file's own units and axes, for keying onto an armature:
    ``names`` (J,), ``grot`` (T, J, 4) wxyz, ``gpos`` (T, J, 3), ``parents`` (J,), ``offsets`` (J, 3), ``ends`` (J, 3) (End Site offsets, NaN where none), ``fps``."""
    from motioncore.bvh import read_bvh
    from motioncore.kinematics import fk

    motion, layout = read_bvh(bvh)
    grot, gpos = fk(motion.lrot, motion.lpos, motion.skeleton.parents)
    unit = 1.0 / layout.scale
    sk = motion.skeleton
    ends = np.full((sk.num_joints, 3), np.nan)
    for j, off in sk.end_sites.items():
        ends[j] = off.numpy() * unit
    return {"names": np.array(sk.names), "grot": grot.numpy().astype(np.float64),
            "gpos": gpos.numpy().astype(np.float64) * unit, "parents": np.array(sk.parents),
            "offsets": sk.offsets.numpy().astype(np.float64) * unit, "ends": ends, "fps": np.array(motion.fps)}


def _up_axis(bvh: str | os.PathLike) -> str:
    """The file axis ("+Y", "-Z", ...) a BVH skeleton's up is nearest: the humanoid mapping's (its rig's
    basis, decided once in :mod:`motioncore.humanoid`), else the longest side of the rest pose."""
    import torch

    from motioncore import quat
    from motioncore.bvh import read_bvh
    from motioncore.kinematics import rest_positions
    from motioncore.retarget import RetargetError, make_rig

    motion, _ = read_bvh(bvh)
    try:
        basis = make_rig(motion.skeleton, motion).basis
        up = quat.mul_vec(quat.inv(basis), torch.tensor([0.0, 1.0, 0.0]))  # canonical up in the file's axes
    except RetargetError:
        rest = rest_positions(motion.skeleton.offsets, motion.skeleton.parents)
        up = torch.zeros(3)
        up[int((rest.amax(0) - rest.amin(0)).argmax())] = 1.0
    axis = int(up.abs().argmax())
    return ("+" if float(up[axis]) > 0 else "-") + "XYZ"[axis]


def _exact_frame_time(bvh: Path, fps: float) -> None:
    """Blender's BVH exporter writes the frame time to 6 decimals (30 fps reads back as 30.0003, which moves
    every resampled frame); write the scene's rate exactly."""
    text = bvh.read_text(encoding="utf-8")
    start = text.find("Frame Time:")
    if start < 0 or not fps > 0:
        return
    end = text.find("\n", start)
    bvh.write_text(f"{text[:start]}Frame Time: {1.0 / fps!r}{text[end:]}", encoding="utf-8")


def _why_not_written(folder: Path) -> str:
    """Why a file in temporary ``folder`` may be missing, for an error: a full disk (say so, and how to choose
    another folder), else nothing."""
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return ""
    if free < 16 << 20:
        root = next((p.parent for p in (folder, *folder.parents) if p.name.startswith(TEMP_PREFIX)), folder.parent)
        return (f" in {root}: its disk is full ({free / 1e6:.1f} MB free); free some space or set TMPDIR "
                "to a folder on another disk")
    return ""


TEMP_PREFIX = "video2style-interchange-"  # then the pid of the process that made the folder


def sweep_stale_folders(tmp: str | os.PathLike | None = None) -> int:
    """Remove the temporary folders (``video2style-interchange-PID-*`` in ``tmp``, default the system's) that a
    process of this user left when it was killed: its pid no longer runs. Returns how many."""
    removed = 0
    root = Path(tmp or tempfile.gettempdir())
    try:
        found = list(root.glob(f"{TEMP_PREFIX}*-*"))
    except OSError:
        return 0
    for folder in found:
        pid = folder.name[len(TEMP_PREFIX):].split("-", 1)[0]
        try:
            st = folder.lstat()
        except OSError:
            continue
        if not pid.isdigit() or not folder.is_dir() or folder.is_symlink() or st.st_uid != os.getuid():
            continue
        if int(pid) != os.getpid() and not _running(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)
            removed += 1
    return removed


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists (another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class Converter:
    """FBX/glTF <-> BVH for one command: :meth:`to_bvh` reads a clip (BVH paths pass through), :meth:`write`
    publishes a BVH result in a format, onto the clip's own file when it came from one. One Blender process
    and one temporary folder for all of it; ``notify(line)`` hears which armature/action was used."""

    def __init__(self, armature: str | None = None, action: str | None = None, notify=None):
        self.armature, self.action, self.notify = armature, action, notify
        self.blender = Blender()
        self._tmp: list[Path] = []  # the temporary folder, once made
        self._read: dict[Path, tuple[Path, dict]] = {}
        self._count = 0  # clips read (or tried): each gets its own temporary subfolder
        self._finalizer = weakref.finalize(self, Converter._cleanup, self.blender, self._tmp)

    @staticmethod
    def _cleanup(blender: Blender, tmp: list[Path]) -> None:
        blender.close()
        for folder in tmp:
            shutil.rmtree(folder, ignore_errors=True)
        tmp.clear()

    def _folder(self) -> Path:
        if not self._tmp:
            sweep_stale_folders()
            self._tmp.append(Path(tempfile.mkdtemp(prefix=f"{TEMP_PREFIX}{os.getpid()}-")))
        return self._tmp[0]

    def to_bvh(self, path: str | os.PathLike) -> Path:
        """``path`` itself for a BVH; for FBX/glTF a BVH of its armature's action (named like the file)."""
        path = Path(path)
        if not is_clip_file(path):
            return path
        if path in self._read:
            return self._read[path][0]
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such file")
        if path.stat().st_size == 0:
            raise InterchangeError(f"{path}: is empty (0 bytes); not an {path.suffix[1:].upper()} file")
        check_resources(path)
        self._count += 1
        where = self._folder() / str(self._count)  # a number of its own: a file that failed keeps none
        where.mkdir()
        bvh = where / f"{path.stem}.bvh"
        try:
            info = self.blender.call({"op": "read", "path": str(path.resolve()), "bvh": str(bvh),
                                      "armature": self.armature, "action": self.action,
                                      "blend": str(where / "scene.blend"), "max_seconds": MAX_CLIP_SECONDS}, path)
            if not bvh.is_file() or bvh.stat().st_size == 0:
                raise InterchangeError(f"{path}: Blender wrote no motion for it{_why_not_written(where)}")
            info["blend"] = str(where / "scene.blend")
            _exact_frame_time(bvh, info["fps"])
        except (InterchangeError, OSError) as e:
            full = _why_not_written(where)  # the temporary folder's disk filled up: say so, not what failed on it
            shutil.rmtree(where, ignore_errors=True)
            if full and "Blender wrote no motion" not in str(e):
                raise InterchangeError(f"{path}: its motion could not be written{full}") from None
            raise
        except BaseException:
            shutil.rmtree(where, ignore_errors=True)
            raise
        if self.notify is not None:
            for note in info.get("notes", []) if isinstance(info.get("notes"), list) else []:
                self.notify(f"note: {path}: {printable(note, 2 * SHOWN_CHARS)}")
        self._read[path] = (bvh, info)
        return bvh

    def named(self, text: str) -> str:
        """``text`` (an error message) with each temporary BVH path replaced by the clip it was read from."""
        for source, (bvh, _) in self._read.items():
            text = text.replace(str(bvh), str(source))
        return text

    def info(self, path: str | os.PathLike) -> dict | None:
        """What reading ``path`` found (armature, action, fps, frame range, meshes); None for a BVH."""
        entry = self._read.get(Path(path))
        return None if entry is None else entry[1]

    def write(self, bvh: str | os.PathLike, out: str | os.PathLike, source: str | os.PathLike | None = None) -> Path:
        """Publish the BVH result ``bvh`` as ``out`` (its suffix says the format), atomically. With ``source``
        (an FBX/glTF clip read by :meth:`to_bvh`) the result is keyed onto that file's armature; else
        (a BVH source) a new armature is made. ``out`` with .bvh is a plain copy."""
        from motioncore.files import atomic_output

        out = Path(out)
        fmt = out.suffix.lower()[1:]
        if fmt not in FORMATS:
            raise ValueError(f"{out}: expected an output ending in .bvh, .fbx, .glb or .gltf")
        if fmt == "bvh":
            with atomic_output(out) as tmp:
                shutil.copyfile(bvh, tmp)
            return out
        arrays = motion_arrays(bvh)
        job = {"op": "write", "out": "", "format": fmt, "armature": self.armature, "action": self.action, "name": out.stem}
        if source is not None and is_clip_file(source):
            if self.info(source) is None:
                self.to_bvh(source)
            read = self.info(source)
            job.update(source=str(Path(source).resolve()), armature=read["armature"], action=read["action"],
                       actions=read.get("actions"), blend=read["blend"])  # the other actions are kept
            arrays["frame_start"] = np.array(read["frame_start"])
        else:
            job.update(source=None, up=_up_axis(bvh))
            arrays["frame_start"] = np.array(1)
        npz = self._folder() / f"motion{len(list(self._folder().glob('motion*.npz')))}.npz"
        try:
            np.savez(npz, **arrays)
        except OSError as e:
            npz.unlink(missing_ok=True)
            raise InterchangeError(f"{out}: the motion could not be handed to Blender"
                                   f"{_why_not_written(npz.parent) or f' ({printable(e.strerror or e)})'}") from None
        job["motion"] = str(npz)
        try:
            with atomic_output(out) as tmp:
                job["out"] = str(Path(tmp).resolve())
                try:
                    self.blender.call(job, Path(source) if source is not None else out,
                                      limit=self.blender.timeout or job_limit(job, int(arrays["grot"].shape[0])))
                except InterchangeError as e:  # Blender names the file it wrote: the temporary one
                    raise InterchangeError(str(e).replace(job["out"], str(out)).replace(str(tmp), str(out))) from None
                if not Path(tmp).is_file() or Path(tmp).stat().st_size == 0:
                    raise InterchangeError(f"{out}: Blender wrote nothing")
        finally:
            npz.unlink(missing_ok=True)
        return out

    def close(self) -> None:
        """End Blender and remove the temporary BVH files (also done when the converter is collected)."""
        self._finalizer()
        self._read.clear()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# ---------------------------------------------------------------------------------------------
# The commands' side: options, folders, and a BVH-only step made to take and give FBX/glTF.


def add_arguments(parser, formats: bool = False) -> None:
    """``--armature``/``--action`` (which ones of an FBX/glTF file), and ``--format`` for commands that write clips."""
    parser.add_argument("--armature", help="FBX/glTF input: the armature to use where a file has several")
    parser.add_argument("--action", help="FBX/glTF input: the action (take) to use where the armature has several")
    if formats:
        parser.add_argument("--format", choices=["bvh", "fbx", "glb", "gltf"],
                            help="write results in this format (default: each input's own; FBX/glTF results keep "
                                 "the input file's mesh, skin and bones; needs Blender, see README)")


def find_clip_files(folder: str | os.PathLike, out_dir: str | os.PathLike | None = None, *,
                    protected: list | None = None) -> list[Path]:
    """The FBX/glTF files in ``folder`` and its subfolders (any case of the suffix), sorted; results left out as
    :func:`video2style.pipeline.content_clips` leaves them: those in ``out_dir`` and in any subfolder holding
    an earlier run's lock file. ``protected``, a list, receives the files left out that no run of ours wrote (in
    ``out_dir`` before it was ever locked): the user's, which no output may overwrite."""
    from video2style.paths import LOCK_NAME, inside, same_path

    folder = Path(folder)
    found = [p for p in folder.rglob("*") if p.suffix.lower() in CLIP_SUFFIXES and p.is_file()]
    marked = [lock.parent for lock in folder.rglob(LOCK_NAME) if lock.parent != folder]
    results = list(marked)
    if out_dir is not None and inside(out_dir, folder) and not same_path(out_dir, folder):
        results.append(Path(out_dir))
    if protected is not None:
        protected += [p for p in found if any(inside(p, r) for r in results) and not any(inside(p, r) for r in marked)]
    return sorted(p for p in found if not any(inside(p, r) for r in results))


def result_suffixes(clip: str | os.PathLike, fmt: str | None = None) -> tuple[str, ...]:
    """The suffixes of the result files a run writes for ``clip``: ``.bvh`` (a BVH result, or the BVH step's own
    beside an FBX/glTF one) and the result's format (``fmt``, else the clip's own)."""
    suffix = output_suffix(clip, fmt) if (is_clip_file(clip) or fmt) else ".bvh"
    return tuple(dict.fromkeys((".bvh", suffix)))


def converter_for(args) -> Converter:
    """The command's :class:`Converter` (made once, kept on ``args``; its Blender ends when the command does)."""
    conv = getattr(args, "clip_converter", None)
    if conv is None:
        conv = Converter(getattr(args, "armature", None), getattr(args, "action", None),
                         notify=lambda s: print(s, file=sys.stderr))
        args.clip_converter = conv
    return conv


def named(args, text: str) -> str:
    """An error message of the command with its FBX/glTF clips' temporary BVH files named by the clips."""
    conv = getattr(args, "clip_converter", None)
    return text if conv is None else conv.named(text)


def as_bvh(args, path: str | os.PathLike | None):
    """``path`` for the BVH-only steps: itself for a BVH or video, a BVH of its action for FBX/glTF."""
    if path is None or not is_clip_file(path):
        return path
    return converter_for(args).to_bvh(path)


_SHARED: list[Converter] = []


def shared_converter() -> Converter:
    """One :class:`Converter` for this process (a batch, or one Ray worker): its Blender starts with the first
    FBX/glTF clip and ends with the process."""
    if not _SHARED:
        _SHARED.append(Converter(notify=lambda s: print(s, file=sys.stderr)))
    return _SHARED[0]


def in_formats(args, run_item):
    """``run_item(clip, folder) -> result`` (BVH in, BVH results named in the
    :class:`video2style.result.ApplyResult`'s ``outputs``) made to take FBX/glTF clips and to give each result in
    ``args.format`` (default: the clip's own format)."""
    return in_format(run_item, lambda: converter_for(args), getattr(args, "format", None))


def in_format(run_item, converter, fmt: str | None = None):
    """:func:`in_formats` with ``converter()`` giving the :class:`Converter` (asked only for FBX/glTF work)."""

    def run(path, where):
        suffix = output_suffix(path, fmt) if (is_clip_file(path) or fmt) else ".bvh"
        if not is_clip_file(path) and suffix == ".bvh":
            return run_item(path, where)
        conv = converter()
        try:
            result = run_item(conv.to_bvh(path), where)
        except ValueError as e:  # a message naming the temporary BVH names the user's file instead
            raise InterchangeError(conv.named(str(e))) from e
        result.input = str(path)
        outs = result.outputs
        if suffix == ".bvh":
            return result
        written = []
        try:
            for out in outs:
                written.append(str(conv.write(out, Path(out).with_suffix(suffix),
                                              source=path if is_clip_file(path) else None)))
        except BaseException:  # a clip's outputs all or none: its preview goes too, and results already written
            for extra in [*written, result.preview, result.player]:
                if extra:
                    Path(extra).unlink(missing_ok=True)
            raise
        finally:
            for out in outs:  # the BVH step's own results
                Path(out).unlink(missing_ok=True)
        result.outputs = written
        return result

    return run
