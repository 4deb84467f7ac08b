import io
import json
import tarfile

import pytest
import torch
from safetensors.torch import load_file

from mlcore.captions import caption
from mlcore.dataset import MotionDataset, build_dataset
from motioncore.bvh import BvhLayout, format_bvh
from motioncore.representation import FEATURES
from motioncore.retarget import from_canonical, make_rig
from testkit.motions import CANONICAL_NAMES_MAP, bandai_like_skeleton, random_motion


def _fake_bandai(path, contents=("walk", "wave-left-hand"), styles=("normal", "elderly"), per_cell=12):
    rig = make_rig(bandai_like_skeleton(), joint_map=CANONICAL_NAMES_MAP)
    rot = ("Zrotation", "Xrotation", "Yrotation")
    layout = BvhLayout(tuple(("Xposition", "Yposition", "Zposition") + rot for _ in rig.skeleton.names), 0.01)
    with tarfile.open(path, "w:xz") as tar:
        k = 0
        for c in contents:
            for s in styles:
                for i in range(per_cell):
                    m = random_motion(seconds=1.5, fps=30.0, seed=k)
                    k += 1
                    data = format_bvh(from_canonical(m, rig), layout).encode()
                    info = tarfile.TarInfo(f"Bandai-Namco-Research-Motiondataset-2/data/dataset-2_{c}_{s}_{i:03d}.bvh")
                    info.size = len(data)
                    tar.addfile(info, io.BytesIO(data))


@pytest.mark.slow
def test_build_dataset_from_archive(tmp_path):
    archive = tmp_path / "bandai2.tar.xz"
    _fake_bandai(archive)
    summary = build_dataset([archive], tmp_path / "cache", progress=False)
    assert summary["clips"] == 2 * 2 * 12 * 2 and not summary["failed"]
    records = json.loads((tmp_path / "cache" / "clips.json").read_text())
    split = json.loads((tmp_path / "cache" / "split.json").read_text())
    assert len(split["test"]) == 4 * 6 and len(split["val"]) == 4 * 3
    # mirrored copies swap left and right and share their clip's split
    by_name = {r["name"]: r for r in records}
    for r in records:
        if r["mirrored"]:
            orig = by_name[r["name"][: -len("_mirror")]]
            assert r["split"] == orig["split"]
            expect = "wave-right-hand" if orig["content"] == "wave-left-hand" else orig["content"]
            assert r["content"] == expect and r["caption"] == caption(expect, r["style"])
    assert by_name["dataset-2_walk_normal_000"]["caption"] == "a person walks"
    assert by_name["dataset-2_walk_elderly_000"]["caption"] == "a person walks, elderly style"
    feats = load_file(str(tmp_path / "cache" / "features.safetensors"))
    assert feats["features"].shape == (sum(r["length"] for r in records), FEATURES.dim)
    assert records[0]["length"] == 30  # 1.5 s at 20 fps

    ds = MotionDataset(tmp_path / "cache", "train")
    x, valid, _idx = ds.sample_windows(5, 40, torch.Generator().manual_seed(0))
    assert x.shape == (5, 40, FEATURES.dim) and valid[:, :30].all() and not valid[:, 30:].any()
    assert abs(float(ds.standardize(ds.features).mean())) < 0.5


@pytest.mark.slow
def test_split_is_reproducible(tmp_path):
    archive = tmp_path / "bandai2.tar.xz"
    _fake_bandai(archive, contents=("run",), styles=("active",), per_cell=10)
    build_dataset([archive], tmp_path / "a", seed=3, progress=False)
    build_dataset([archive], tmp_path / "b", seed=3, progress=False)
    assert (tmp_path / "a" / "split.json").read_text() == (tmp_path / "b" / "split.json").read_text()


def test_missing_archive_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.tar.xz"):
        build_dataset([tmp_path / "nope.tar.xz"], tmp_path / "out", progress=False)
