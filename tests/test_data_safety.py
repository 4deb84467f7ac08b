"""Nothing the user had is lost (issue 25, part A): outputs never overwrite inputs, the batch sweeps only its own
temporary files, one run per output folder, results are never read back as content, and a shared output folder
cannot make a run write through a planted symlink. Generated inputs only."""
import os
import threading
from pathlib import Path

import pytest

from motioncore.files import is_temp_name, temp_beside
from tests.test_hardening import _clip, _FakeStyle, _library, fake_pipeline  # noqa: F401 - a fixture, used by fake
from video2style import batch
from video2style.cli import main
from video2style.paths import LOCK_NAME, check_outputs, same_path


@pytest.fixture
def fake(fake_pipeline):  # noqa: F811 - test_hardening's fake learn/apply (calls recorded)
    return fake_pipeline


def _snapshot(root: Path) -> dict[str, bytes | None]:
    """Every path under ``root`` with its bytes (None for folders and links): what a refused run must leave alone."""
    out = {}
    for p in sorted(root.rglob("*")):
        out[str(p.relative_to(root))] = p.read_bytes() if p.is_file() and not p.is_symlink() else None
    return out


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A folder of inputs, the current directory: ``c.bvh`` (a clip), ``x.mp4`` (video bytes), ``lib/`` (clips),
    ``videos/`` (a video), ``m.json``, ``d/`` (a dataset folder), ``runs/prior/denoiser.safetensors``, a symlink
    and a hard link to ``c.bvh``, and ``w.safetensors``."""
    monkeypatch.chdir(tmp_path)
    _clip(tmp_path / "c.bvh")
    (tmp_path / "x.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42 not really a video")
    for rel in ("lib/walk.bvh", "lib/sub/run.bvh"):
        _clip(tmp_path / rel)
    (tmp_path / "videos").mkdir()
    (tmp_path / "videos" / "lib.mp4").write_bytes(b"video")
    (tmp_path / "m.json").write_text("{}")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "features.safetensors").write_bytes(b"data")
    (tmp_path / "runs" / "prior").mkdir(parents=True)
    (tmp_path / "runs" / "prior" / "denoiser.safetensors").write_bytes(b"prior")
    (tmp_path / "runs" / "prior" / "checkpoint.safetensors").write_bytes(b"prior checkpoint")
    (tmp_path / "w.safetensors").write_bytes(b"weights")
    (tmp_path / "s.v2s").write_bytes(b"style")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "c_player.js").write_text("{}")  # read as a joint map below
    (tmp_path / "link.bvh").symlink_to(tmp_path / "c.bvh")
    os.link(tmp_path / "c.bvh", tmp_path / "hard.bvh")
    return tmp_path


REFUSED = [  # command line -> each writes over one of its inputs (spelled another way, through a link, ...)
    ["pose", "x.mp4", "-o", "x.mp4"],
    ["pose", "x.mp4", "--preview", "x.mp4"],
    ["pose", "x.mp4", "-o", "./lib/../x.mp4"],
    ["pose", "x.mp4", "-o", "p.bvh", "--preview", "./p.bvh"],  # two outputs, one file
    ["learn", "c.bvh", "-o", "c.bvh"],
    ["learn", "c.bvh", "-o", "link.bvh"],  # a symlink to the input
    ["learn", "c.bvh", "-o", "hard.bvh"],  # a hard link to the input
    ["learn", "c.bvh", "-o", "m.json", "--joint-map", "m.json"],
    ["learn", "x.mp4", "-o", "{tmp}/x.mp4"],  # an absolute spelling
    ["skeleton", "c.bvh", "--write-map", "c.bvh"],
    ["skeleton", "c.bvh", "--preview", "../{name}/c.bvh"],
    ["skeleton", "c.bvh", "--write-map", "m.json", "--joint-map", "m.json"],
    ["skeleton", "c.bvh", "--write-map", "r.json", "--preview", "r.json"],
    ["preview", "c.bvh", "lib/walk.bvh", "-o", "lib/walk.bvh"],
    ["apply", "s.v2s", "c.bvh", "-o", "."],  # the clip's own folder: c.bvh would be replaced by its result
    ["apply", "s.v2s", "lib/walk.bvh", "-o", "lib/"],
    ["apply", "s.v2s", "lib", "-o", "lib"],  # a folder input into itself
    ["apply", "s.v2s", "lib", "-o", "./lib/../lib"],
    ["apply", "s.v2s", "c.bvh", "-o", "out", "--joint-map", "out/c_player.js"],
    ["apply", "--method", "park", "--domain", "elderly", "lib/sub/run.bvh", "-o", "lib/sub"],
    ["apply", "--method", "park", "--domain", "elderly", "c.bvh", "-o", "o", "--reference", "o/c.bvh"],
    ["batch", "videos", "--content", "lib", "-o", "lib"],
    ["batch", "videos", "--content", "lib", "-o", "."],  # the video lib.mp4's results would go to ./lib, among the clips
    ["batch", "videos", "--content", "lib/sub", "-o", "."],
    ["train-prior", "--data", "d", "--out", "./d"],
    ["train-encoder", "--data", "d", "--prior", "runs/prior/denoiser.safetensors", "--out", "runs/prior"],
    ["train-park", "--data", "d", "--init", "w.safetensors", "--weights", "w.safetensors"],
    ["train-classifier", "--target", "style", "--data", "d", "--out", "d"],
    ["train-classifier", "--target", "style", "--data", "d", "--weights", "d/features.safetensors"],
    ["evaluate", "--data", "d", "-o", "d"],
    ["evaluate", "--data", "d", "--style-cache", "d"],
]


@pytest.mark.parametrize("argv", REFUSED, ids=[" ".join(a) for a in REFUSED])
def test_an_output_that_is_an_input_is_refused_in_one_line_before_any_work(workdir, capsys, monkeypatch, argv):
    _fake_apply(monkeypatch)  # a style file that loads; a refusal must come before any clip is written
    argv = [a.format(tmp=workdir, name=workdir.name) for a in argv]
    before = _snapshot(workdir)
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and ("would overwrite" in err or "same file" in err or "write results into" in err), err
    assert _snapshot(workdir) == before  # inputs untouched, nothing made


def test_outputs_beside_their_inputs_are_still_allowed(workdir):
    check_outputs([("-o", workdir / "c2.bvh"), ("--preview", workdir / "c.mp4")], [("the input clip", workdir / "c.bvh")])
    check_outputs([("-o", workdir / "out")], [("the folder of the input clip", workdir / "lib")])
    assert same_path(workdir / "link.bvh", "c.bvh") and same_path("lib/../c.bvh", workdir / "hard.bvh")
    assert not same_path("c.bvh", "lib/walk.bvh") and not same_path("new.bvh", "c.bvh")


def test_the_demo_refuses_to_write_into_its_samples(tmp_path):
    from video2style.demo import run_demo

    samples = tmp_path / "pose"
    samples.mkdir()
    (samples / "walk.mp4").write_bytes(b"video")
    _clip(samples / "walk.bvh")
    before = _snapshot(tmp_path)
    for out in (samples, tmp_path):  # the batch's results among the samples; pose's OUT/pose/walk.bvh over walk.bvh
        with pytest.raises(ValueError, match="would overwrite"):
            run_demo(out, progress=lambda s: None, samples=samples)
    assert _snapshot(tmp_path) == before


# 2. The batch's sweep removes only the temporary files this program made.
def test_the_sweep_leaves_files_that_merely_look_like_ours(tmp_path, fake):
    videos, content = _library(tmp_path)
    out = tmp_path / "out"
    (out / "old_mp4").mkdir(parents=True)
    ours = temp_beside(out / "old_mp4" / "walk_preview.mp4")  # what a killed run leaves
    ours.write_bytes(b"half a video")
    users = [out / ".myreport.20241201.tmp", out / "old_mp4" / ".walk_preview.ab12cd34.mp4", out / ".notes.abcdefgh.tmp",
             out / "v2s-tmp-abcdefgh.tmp"]
    for p in users:
        p.write_text("mine")
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    planted = out / f".x{'.v2s-tmp-'}abcdefgh.tmp"  # our shape, but a symlink: never followed, left alone
    planted.symlink_to(victim)
    assert is_temp_name(ours.name) and not any(is_temp_name(p.name) for p in users)
    batch.run_batch(videos, content, out, progress=lambda s: None)
    assert not ours.exists()
    assert all(p.read_text() == "mine" for p in users) and victim.read_text() == "keep me"


# 3. Two apply runs into one folder do not interleave.
def _fake_apply(monkeypatch, gate: threading.Event | None = None, started: threading.Event | None = None):
    """apply's style loading and work replaced: each result names the style file it came from."""
    def load(path):
        s = _FakeStyle()
        s.meta = {"style": Path(path).name}
        return s

    def apply(self, clip, out_dir, request, joint_map=None):
        from video2style.result import ApplyResult

        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / f"{clip.stem}.bvh").write_text(self.style.meta["style"])
        if started is not None:
            started.set()
            gate.wait(30)
        (out_dir / f"{clip.stem}_preview.mp4").write_text(self.style.meta["style"])
        return ApplyResult(str(clip), [str(out_dir / f"{clip.stem}.bvh")], frames=20, seconds_transfer=0.0)

    monkeypatch.setattr("video2style.loaded_style.LoadedStyle.apply", apply)
    monkeypatch.setattr("transfer.bundle.load_models", lambda device="cpu": type("M", (), {"prior": None})())
    monkeypatch.setattr("transfer.style_file.Style.load", staticmethod(load))
    monkeypatch.setattr("transfer.style_file.style_model", lambda prior, style: None)


def test_a_second_apply_into_the_same_folder_is_refused_while_the_first_writes(tmp_path, monkeypatch, capsys):
    gate, started = threading.Event(), threading.Event()
    _fake_apply(monkeypatch, gate, started)
    clip, out = _clip(tmp_path / "in" / "walk.bvh"), tmp_path / "out"
    (tmp_path / "a.v2s").write_text("a")
    (tmp_path / "b.v2s").write_text("b")
    codes = []
    first = threading.Thread(target=lambda: codes.append(main(["apply", str(tmp_path / "a.v2s"), str(clip), "-o", str(out)])))
    first.start()
    assert started.wait(30)
    assert main(["apply", str(tmp_path / "b.v2s"), str(clip), "-o", str(out)]) == 1  # while a.v2s is half written
    gate.set()
    first.join(30)
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln]
    assert codes == [0] and len(err) == 1 and "another apply is writing here" in err[0] and str(out) in err[0]
    pages = ("report.json", "index.html")  # apply's report and page, of the run that wrote: a.v2s's
    assert {p.read_text() for p in out.iterdir() if p.name not in (LOCK_NAME, *pages)} == {"a.v2s"}  # one style's outputs
    assert all("a.v2s" in (out / n).read_text() and "b.v2s" not in (out / n).read_text() for n in pages)
    with batch.folder_lock(out, "batch"):  # and a batch holding the folder stops an apply before any work
        assert main(["apply", str(tmp_path / "b.v2s"), str(clip), "-o", str(out)]) == 1
    assert "another batch is writing here" in capsys.readouterr().err
    assert {p.read_text() for p in out.iterdir() if p.name not in (LOCK_NAME, *pages)} == {"a.v2s"}


# 4. A batch never reads its own results back as content.
def test_a_batch_with_its_output_inside_the_content_never_restyles_its_results(tmp_path, fake, capsys):
    videos, content = _library(tmp_path)
    out = content / "results"
    batch.run_batch(videos, content, out, progress=lambda s: None)
    first = sorted(fake["apply"])
    assert len(first) == 9 and not any(Path(c).is_relative_to(out) for c in first)
    fake["apply"].clear()
    report = batch.run_batch(videos, content, out, progress=print)  # a rerun: all done, none of the results taken
    assert fake["apply"] == [] and len(report.rows) == 9
    assert "results are not read back as content" in capsys.readouterr().out
    batch.run_batch(videos, content, content / "again", progress=lambda s: None)  # another -o: the first results
    assert not any(Path(c).is_relative_to(out) for c in fake["apply"])  # an output folder still (its lock)
    assert main(["batch", str(videos), "--content", str(content), "-o", str(content)]) == 1


def test_apply_from_a_folder_into_a_subfolder_does_not_take_its_results_as_clips(tmp_path, monkeypatch):
    _fake_apply(monkeypatch)
    lib = tmp_path / "lib"
    _clip(lib / "walk.bvh")
    (tmp_path / "s.v2s").write_text("s")
    for _ in range(2):
        assert main(["apply", str(tmp_path / "s.v2s"), str(lib), "-o", str(lib / "styled")]) == 0
    assert sorted(p.relative_to(lib).as_posix() for p in lib.rglob("*.bvh")) == ["styled/walk.bvh", "walk.bvh"]


# 5. A shared output folder cannot make a run write through a planted symlink.
def test_a_symlink_planted_at_the_lock_is_refused_and_its_target_unchanged(tmp_path, fake, capsys):
    videos, content = _library(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's file")
    (out / LOCK_NAME).symlink_to(victim)
    assert main(["batch", str(videos), "--content", str(content), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "symbolic link" in err and LOCK_NAME in err
    assert victim.read_text() == "the user's file" and fake["learn"] == []
    (out / LOCK_NAME).unlink()
    (out / LOCK_NAME).symlink_to(tmp_path / "nowhere")  # a dangling link is not created through either
    with pytest.raises(RuntimeError, match="symbolic link"):
        batch.run_batch(videos, content, out, progress=lambda s: None)
    assert not (tmp_path / "nowhere").exists()
    (out / LOCK_NAME).unlink()
    os.mkfifo(out / LOCK_NAME)  # not a regular file
    with pytest.raises(RuntimeError, match="not a regular file"):
        batch.run_batch(videos, content, out, progress=lambda s: None)


def test_a_result_folder_planted_as_a_symlink_is_refused(tmp_path, fake):
    videos, content = _library(tmp_path)
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (elsewhere / "run.bvh").write_text("the user's clip")
    (out / "strut").symlink_to(elsewhere)
    with pytest.raises(ValueError, match="symbolic link"):
        batch.run_batch(videos, content, out, progress=lambda s: None)
    (out / "strut").unlink()
    (out / "strut").mkdir()
    (out / "strut" / "a").symlink_to(elsewhere)  # deeper: where content/a/walk.bvh's result goes
    with pytest.raises(ValueError, match="strut/a: is a symbolic link inside -o"):
        batch.run_batch(videos, content, out, progress=lambda s: None)
    assert (elsewhere / "run.bvh").read_text() == "the user's clip" and fake["learn"] == []
    assert sorted(p.name for p in elsewhere.iterdir()) == ["run.bvh"]


def test_apply_does_not_write_through_a_link_planted_in_its_output_folder(tmp_path, monkeypatch, capsys):
    _fake_apply(monkeypatch)
    lib, out, elsewhere = tmp_path / "lib", tmp_path / "out", tmp_path / "elsewhere"
    _clip(lib / "sub" / "walk.bvh")
    elsewhere.mkdir()
    (elsewhere / "walk.bvh").write_text("the user's clip")
    out.mkdir()
    (out / "sub").symlink_to(elsewhere)
    (tmp_path / "s.v2s").write_text("s")
    assert main(["apply", str(tmp_path / "s.v2s"), str(lib), "-o", str(out)]) == 1
    assert "is a symbolic link inside -o" in capsys.readouterr().err
    assert [p.name for p in elsewhere.iterdir()] == ["walk.bvh"] and (elsewhere / "walk.bvh").read_text() == "the user's clip"


def test_links_planted_at_the_index_and_report_are_replaced_not_written_through(tmp_path, fake):
    videos, content = _library(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    victims = {name: tmp_path / f"victim_{name}" for name in ("index.html", "report.json")}
    for name, victim in victims.items():
        victim.write_text("the user's file")
        (out / name).symlink_to(victim)
    batch.run_batch(videos, content, out, progress=lambda s: None)
    for name, victim in victims.items():  # the rename replaces the link itself
        assert victim.read_text() == "the user's file" and not (out / name).is_symlink()


def test_the_users_clips_in_an_output_folder_inside_the_input_are_not_overwritten(tmp_path, monkeypatch, fake, capsys):
    _fake_apply(monkeypatch)
    lib = tmp_path / "lib"
    _clip(lib / "walk.bvh")
    _clip(lib / "sub" / "walk.bvh")  # the user's, in what -o names: left out as content, yet never overwritten
    (tmp_path / "s.v2s").write_text("s")
    before = _snapshot(tmp_path)
    assert main(["apply", str(tmp_path / "s.v2s"), str(lib), "-o", str(lib / "sub")]) == 1
    assert "is a clip in the input folder" in capsys.readouterr().err and _snapshot(tmp_path) == before
    videos = tmp_path / "videos"
    videos.mkdir()
    (videos / "old.mp4").write_bytes(b"video")
    _clip(lib / "res" / "old" / "walk.bvh")  # where the batch would put lib/walk.bvh's result for old.mp4
    before = _snapshot(tmp_path)
    with pytest.raises(ValueError, match="is a clip in the --content folder"):
        batch.run_batch(videos, lib, lib / "res", progress=lambda s: None)
    assert _snapshot(tmp_path) == before and fake["learn"] == []


def test_runs_into_nested_folders_do_not_interleave(tmp_path, monkeypatch, fake, capsys):
    _fake_apply(monkeypatch)
    clip, out = _clip(tmp_path / "in" / "walk.bvh"), tmp_path / "out"
    (tmp_path / "s.v2s").write_text("s")
    with batch.folder_lock(out, "batch"):  # a batch writing OUT: an apply into OUT/sub is refused
        assert main(["apply", str(tmp_path / "s.v2s"), str(clip), "-o", str(out / "sub")]) == 1
    assert f"{out / 'sub'}: another batch is writing in {out}" in capsys.readouterr().err
    assert not (out / "sub" / "walk.bvh").exists()
    with batch.folder_lock(out / "old", "apply"):  # an apply writing OUT/old: a batch into OUT is refused before its sweep
        stale = temp_beside(out / "old" / "walk.bvh")  # the apply's file in progress
        videos, content = _library(tmp_path)
        with pytest.raises(RuntimeError, match="another apply is writing in"):
            batch.run_batch(videos, content, out, progress=lambda s: None)
        assert stale.exists() and fake["learn"] == []
        assert main(["apply", str(tmp_path / "s.v2s"), str(tmp_path / "in"), "-o", str(out)]) == 0  # elsewhere in OUT: fine
