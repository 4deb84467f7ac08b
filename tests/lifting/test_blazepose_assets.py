"""Obtaining the BlazePose ONNX models: cache dirs, wheel checks, offline errors."""

from __future__ import annotations

import hashlib
import subprocess
import sys
import zipfile

import numpy as np
import onnx
import onnxruntime as ort
import pytest
from onnx import TensorProto, helper

from lifting.blazepose import assets
from lifting.blazepose.assets import (
    CACHE_ENV,
    CONVERTER_TAG,
    LANDMARK_OUTPUTS,
    MODELS,
    WHEEL_ENV,
    ModelUnavailableError,
    ensure_models,
    model_dir,
    read_wheel_member,
    resolve_cache_dir,
)


@pytest.fixture
def no_env(monkeypatch):
    monkeypatch.delenv(CACHE_ENV, raising=False)
    monkeypatch.delenv(WHEEL_ENV, raising=False)


@pytest.fixture
def no_network(monkeypatch):
    """pip download fails as it would without a registry."""

    def fake_run(cmd, **kwargs):
        assert cmd[:3] == [sys.executable, "-m", "pip"] and "mediapipe==0.10.14" in cmd
        return subprocess.CompletedProcess(cmd, 1, "", "ERROR: Could not find a version (network unreachable)")

    monkeypatch.setattr(assets.subprocess, "run", fake_run)


def test_cache_dir_precedence(tmp_path, monkeypatch, no_env):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert resolve_cache_dir() == tmp_path / "xdg" / "video2style"
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "env"))
    assert resolve_cache_dir() == tmp_path / "env"
    assert resolve_cache_dir(tmp_path / "arg") == tmp_path / "arg"


def test_existing_files_are_used_without_download(tmp_path, no_env, no_network):
    folder = model_dir(tmp_path)
    folder.mkdir(parents=True)
    for name in MODELS:
        (folder / f"{name}.onnx").write_bytes(b"x")
    assert ensure_models(tmp_path) == {name: folder / f"{name}.onnx" for name in MODELS}


def test_hand_copied_onnx_files_in_cache_root_are_accepted(tmp_path, no_env, no_network):
    for name in MODELS:
        (tmp_path / f"{name}.onnx").write_bytes(b"x")
    assert ensure_models(tmp_path)["pose_detection"] == tmp_path / "pose_detection.onnx"


def _toy_model(outputs: list[str]) -> onnx.ModelProto:
    """x (1, 2) -> one Relu per output name."""
    x = helper.make_tensor_value_info("input_1", TensorProto.FLOAT, [1, 2])
    nodes = [helper.make_node("Relu", ["input_1"], [name], name=f"node_{name}") for name in outputs]
    outs = [helper.make_tensor_value_info(name, TensorProto.FLOAT, [1, 2]) for name in outputs]
    model = helper.make_model(helper.make_graph(nodes, "toy", [x], outs), opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    return model


def test_a_previous_converters_cache_is_pruned_without_download(tmp_path, no_env, no_network):
    old = tmp_path / "blazepose" / "tflite2onnx-v1"
    old.mkdir(parents=True)
    every = [f"Identity{s}" for s in ("", "_1", "_2", "_3", "_4")]
    onnx.save(_toy_model(every), str(old / "pose_landmark_full.onnx"))
    onnx.save(_toy_model(["Identity", "Identity_1"]), str(old / "pose_detection.onnx"))
    said = []
    paths = ensure_models(tmp_path, notify=said.append)
    assert paths["pose_landmark_full"].parent.name == CONVERTER_TAG
    assert len(said) == 2 and all("no download" in line for line in said)
    landmark = onnx.load(str(paths["pose_landmark_full"]))
    assert [o.name for o in landmark.graph.output] == list(LANDMARK_OUTPUTS)
    assert len(landmark.graph.node) == len(LANDMARK_OUTPUTS)  # the mask's node went with its output
    assert [o.name for o in onnx.load(str(paths["pose_detection"])).graph.output] == ["Identity", "Identity_1"]
    session = ort.InferenceSession(str(paths["pose_landmark_full"]), providers=["CPUExecutionProvider"])
    out = session.run(None, {"input_1": np.array([[-1.0, 2.0]], np.float32)})
    np.testing.assert_array_equal(out[0], [[0.0, 2.0]])


def test_download_failure_explains_offline_setup(tmp_path, no_env, no_network):
    with pytest.raises(ModelUnavailableError) as info:
        ensure_models(tmp_path)
    message = str(info.value)
    assert "pip exited with status 1 (its output is above)" in message  # pip speaks to the terminal itself
    assert "pip download --no-deps --only-binary=:all:" in message and "mediapipe==0.10.14" in message
    assert WHEEL_ENV in message and str(tmp_path) in message
    assert not any(model_dir(tmp_path).glob("*.onnx"))


def test_missing_wheel_path_from_environment(tmp_path, monkeypatch, no_network):
    monkeypatch.setenv(WHEEL_ENV, str(tmp_path / "missing.whl"))
    with pytest.raises(ModelUnavailableError, match="expected a mediapipe wheel file.*missing.whl"):
        ensure_models(tmp_path)


def test_wheel_member_checksum_is_enforced(tmp_path):
    member, sha = MODELS["pose_detection"]
    wheel = tmp_path / "fake.whl"
    with zipfile.ZipFile(wheel, "w") as zf:
        zf.writestr(member, b"not the model")
    with pytest.raises(
        ModelUnavailableError, match=f"expected sha256 {sha}.*got {hashlib.sha256(b'not the model').hexdigest()}"
    ):
        read_wheel_member(wheel, member, sha)
    good = hashlib.sha256(b"not the model").hexdigest()
    assert read_wheel_member(wheel, member, good) == b"not the model"
    with pytest.raises(ModelUnavailableError, match="expected member"):
        read_wheel_member(wheel, MODELS["pose_landmark_full"][0], sha)
    (tmp_path / "bad.whl").write_text("no zip")
    with pytest.raises(ModelUnavailableError, match="to be a wheel"):
        read_wheel_member(tmp_path / "bad.whl", member, sha)


def test_cached_models_are_valid_onnx(blazepose_models):
    det = onnx.load(str(blazepose_models["pose_detection"]))
    lm = onnx.load(str(blazepose_models["pose_landmark_full"]))
    assert [i.name for i in det.graph.input] == ["input_1"]
    assert [o.name for o in det.graph.output] == ["Identity", "Identity_1"]
    assert [o.name for o in lm.graph.output] == list(LANDMARK_OUTPUTS)  # the segmentation mask is cut
    assert "Identity_2" not in LANDMARK_OUTPUTS
    dims = [d.dim_value for d in lm.graph.input[0].type.tensor_type.shape.dim]
    assert dims == [1, 256, 256, 3]  # NHWC kept
    assert det.opset_import[0].version == 13


@pytest.mark.slow
def test_conversion_from_local_wheel_into_fresh_cache(tmp_path, blazepose_models, no_env):
    """The full path (wheel → checksum → convert → atomic write) into an empty cache."""
    try:
        wheel = assets.download_wheel(tmp_path / "dl")
    except ModelUnavailableError as exc:
        pytest.skip(f"mediapipe wheel unavailable: {str(exc).splitlines()[0]}")
    paths = ensure_models(tmp_path / "cache", wheel=wheel)
    for name, path in paths.items():
        assert path.read_bytes() == blazepose_models[name].read_bytes()  # conversion is deterministic
        assert path.stat().st_mode & 0o044  # readable by others, like a normal file
    assert not [p for p in paths["pose_detection"].parent.iterdir() if p.suffix == ".tmp"]
