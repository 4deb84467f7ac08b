"""A plain (not editable) install has everything the commands read: weights, the caption table, the samples."""
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_the_wheel_holds_weights_samples_and_the_console_script(tmp_path):
    pytest.importorskip("setuptools", reason="building the wheel offline needs setuptools in this environment")
    subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path)], check=True, cwd=tmp_path)
    wheel = next(tmp_path.glob("video2style-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    for need in ("mlcore/weights/denoiser.safetensors", "mlcore/weights/motion_encoder.safetensors",
                 "mlcore/weights/captions.safetensors", "mlcore/weights/park_stylizer.safetensors",
                 *(f"video2style/samples/{p.name}" for p in (ROOT / "samples").iterdir() if p.suffix in (".bvh", ".mp4")),
                 "video2style/samples/elderly.mp4", "video2style/samples/walk_prior.bvh", "video2style/cli.py",
                 "motioncore/humanoid/__init__.py", "motioncore/humanoid/limb_chains.py", "video2style/blender_io.py", "lifting/lift.py", "lifting/reconstruct.py", "evaluation/protocol.py",
                 "park/infer.py", "park/graph.py"):
        assert need in names, need
    assert not any(n.startswith("samples/") for n in names)  # the top-level samples/ installs as video2style/samples/
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    assert "video2style = video2style.cli:console_main" in zipfile.ZipFile(wheel).read(entry).decode()
    # installed somewhere else, the package finds its own samples and weights
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target), str(wheel)],
                   check=True, cwd=tmp_path)
    code = ("from video2style.demo import SAMPLES; from video2style.pipeline import find_bvh_files, weights_path; "
            "print(SAMPLES); print(len(find_bvh_files(SAMPLES, recursive=False))); "
            "print(weights_path('denoiser.safetensors'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path,
                         env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"}).stdout.split()
    assert out[0].startswith(str(target)) and int(out[1]) >= 4 and out[2].startswith(str(target))
