import subprocess
import sys

import pytest

from video2style.cli import main


def run(*args):
    return subprocess.run([sys.executable, "-m", "video2style", *args], capture_output=True, text=True, timeout=120, check=False)


def test_help_lists_commands_with_examples():
    r = run("--help")
    assert r.returncode == 0
    for cmd in ("demo", "learn", "apply", "batch", "preview", "dataset", "train-prior"):
        assert cmd in r.stdout
    assert "examples:" in r.stdout


@pytest.mark.slow
def test_preview_of_a_malformed_bvh_is_one_line_naming_file_and_line(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 zero 0\n")
    out = tmp_path / "out.mp4"
    r = run("preview", str(bad), "-o", str(out))
    assert r.returncode == 1
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and f"{bad}:4:" in lines[0]
    assert not out.exists() and not list(tmp_path.glob("*.tmp*"))


def test_apply_with_a_garbage_style_file(tmp_path, capsys):
    style = tmp_path / "x.v2s"
    style.write_text("nope")
    assert main(["apply", str(style), str(tmp_path), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(style) in err


def test_bad_strength_is_rejected(tmp_path, capsys):
    assert main(["apply", "a.v2s", "b.bvh", "-o", str(tmp_path), "--strength", "3"]) == 1
    assert "strength" in capsys.readouterr().err


def test_dataset_needs_an_archive(capsys):
    assert main(["dataset"]) == 1
    assert "--bandai2" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["learn"], ["apply"], ["nonsense"]])
def test_usage_errors_exit_nonzero(argv):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2


def test_output_locations_are_checked_before_any_work(tmp_path, capsys):
    clip = tmp_path / "c.bvh"
    clip.write_text("not read: the output is checked first")
    folder = tmp_path / "folder"
    folder.mkdir()
    assert main(["preview", str(clip), "-o", str(folder)]) == 1
    assert f"{folder}: -o names a folder" in capsys.readouterr().err
    assert main(["learn", str(clip), "-o", str(folder)]) == 1
    assert "names a folder" in capsys.readouterr().err
    afile = tmp_path / "file.txt"
    afile.write_text("x")
    assert main(["apply", "a.v2s", str(clip), "-o", str(afile)]) == 1
    assert f"{afile}: -o names a file" in capsys.readouterr().err


def test_a_full_disk_is_one_line_and_leaves_no_temp_file(tmp_path, capsys, monkeypatch):
    import errno
    import os

    from motioncore.bvh import BvhLayout, write_bvh
    from motioncore.skeleton import CANONICAL
    from testkit.motions import random_motion

    clip = tmp_path / "c.bvh"
    write_bvh(clip, random_motion(seconds=1.0), BvhLayout.default(CANONICAL.skeleton, scale=0.01))
    out = tmp_path / "out" / "c.mp4"

    def full(src, dst):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(dst))

    monkeypatch.setattr("motioncore.files.publish", full)
    assert main(["preview", str(clip), "-o", str(out)]) == 1
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and not ln.startswith(("rendering", "\r"))]
    assert err == [f"video2style preview: error: {out}: No space left on device"]
    assert not out.exists() and not [p for p in out.parent.iterdir() if p.name.startswith(".")]


def test_small_things_users_notice(tmp_path, capsys):
    import pytest

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.startswith("video2style ")
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert main(["demo", "-o", str(afile)]) == 1
    assert "names a file; give a folder" in capsys.readouterr().err
    assert main(["preview", "a.bvh", "-o", str(tmp_path / "x.gif")]) == 1
    assert "previews are .mp4" in capsys.readouterr().err and not (tmp_path / "x.gif").exists()
    assert main(["preview", "a.bvh", "-o", str(afile / "x.mp4")]) == 1
    assert "is a file" in capsys.readouterr().err
    from video2style.cli import build_parser

    for action in build_parser()._subparsers._group_actions[0].choices["apply"]._actions:
        assert action.help, action.option_strings


def test_models_is_an_explicit_step_with_an_offline_route(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("VIDEO2STYLE_CACHE", str(tmp_path / "cache"))
    assert main(["models", "--check"]) == 1
    err = capsys.readouterr().err
    assert "missing" in err and "36 MB" in err and "Apache" in err and "--wheel" in err
    bad = tmp_path / "bad.whl"
    bad.write_text("not a zip")
    assert main(["models", "--wheel", str(bad)]) == 1
    assert "not a zip file" in capsys.readouterr().err
    assert main(["models", "--wheel", str(tmp_path / "missing.whl")]) == 1
    assert "no such file" in capsys.readouterr().err


def test_console_script_returns_mains_status_and_freezes_the_heap_for_a_quick_exit(tmp_path, monkeypatch, capsys):
    import gc

    from video2style.cli import console_main

    afile = tmp_path / "afile"
    afile.write_text("x")
    monkeypatch.setattr(sys, "argv", ["video2style", "demo", "-o", str(afile)])
    gc.unfreeze()
    try:
        assert console_main() == 1  # main's own status and its one-line error
        assert "names a file; give a folder" in capsys.readouterr().err
        assert gc.get_freeze_count() > 0  # the interpreter's exit will not sweep these objects again
    finally:
        gc.unfreeze()
