"""``--device auto|cpu|cuda``: names resolved in one place and checked before any work, the method's tensors on
the models' device, CPU results unchanged, Ray tasks asking for a GPU only for cuda. No GPU needed: torch's view
of CUDA is patched where a test needs one or none."""
from __future__ import annotations

import copy
import subprocess
import sys

import pytest
import torch

from mlcore.device import DEVICES, resolve_device
from mlcore.shipped import SHIPPED
from motioncore.representation import FEATURES
from video2style.demo import SAMPLES


@pytest.fixture
def no_gpu(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)


def test_device_names_resolve_in_one_place(no_gpu, monkeypatch):
    assert resolve_device("auto") == resolve_device("cpu") == torch.device("cpu")
    assert resolve_device(torch.device("cpu")) == torch.device("cpu")
    with pytest.raises(ValueError) as e:
        resolve_device("cuda")
    assert "\n" not in str(e.value) and str(e.value).startswith("--device cuda: torch sees no CUDA GPU (this torch is ")
    assert str(e.value).endswith("use --device cpu or auto")
    with pytest.raises(ValueError, match=r"^--device: expected one of auto, cpu, cuda, got 'gpu'$"):
        resolve_device("gpu")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)  # a machine with a GPU: no CUDA call is made
    monkeypatch.setattr(torch.cuda, "current_device", lambda: 0)
    assert resolve_device("auto") == resolve_device("cuda") == torch.device("cuda", 0)


def test_the_device_names_import_without_torch():
    code = "import sys, mlcore.device as d; assert 'torch' not in sys.modules; print(','.join(d.DEVICES))"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    assert out.strip() == ",".join(DEVICES)


@pytest.mark.parametrize("argv", [
    ["learn", "walk.bvh"], ["apply", "old.v2s", "walk.bvh"], ["batch", "videos", "--content", "lib"],
    ["batch", "videos", "--content", "lib", "--ray"], ["train-prior"], ["train-encoder", "--prior", "p.safetensors"],
    ["train-park"], ["train-classifier", "--target", "style"], ["apply", "--method", "park", "--domain", "elderly", "walk.bvh"],
])
def test_cuda_without_a_gpu_is_one_line_and_exit_2_before_any_work(argv, no_gpu, tmp_path, capsys, monkeypatch):
    from video2style.cli import main

    monkeypatch.chdir(tmp_path)
    out = ["--out" if argv[0].startswith("train") else "-o", str(tmp_path / "out")]
    assert main([*argv, *out, "--device", "cuda"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"video2style {argv[0]}: error: --device cuda: torch sees no CUDA GPU")
    assert list(tmp_path.iterdir()) == []


def test_device_option_on_the_commands_that_run_models(no_gpu):
    from video2style.cli import _device_error, build_parser

    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices
    for name, sub in commands.items():
        has = any("--device" in a.option_strings for a in sub._actions)
        assert has == (name in ("learn", "apply", "batch", "train-prior", "train-encoder", "train-park",
                                "train-classifier")), name
        assert sub.get_default("device") == ("cpu" if has else None)
    # a batch joining a Ray cluster is checked against the cluster's GPUs, not this machine's
    args = parser.parse_args(["batch", "v", "--content", "c", "-o", "o", "--ray", "auto", "--device", "cuda"])
    assert _device_error(args) is None


def test_ray_tasks_ask_for_a_gpu_only_for_cuda(no_gpu):
    from video2style.batch_ray import task_device, task_options

    assert task_options("cpu") == {"num_cpus": 1, "max_retries": 3}
    assert task_options("cuda") == {"num_cpus": 1, "max_retries": 3, "num_gpus": 1}
    with pytest.raises(ValueError, match="expected 'cpu' or 'cuda', got 'auto'"):
        task_options("auto")
    # a local Ray: this machine's torch decides (no GPU here)
    assert task_device("cpu", None) == task_device("auto", None) == "cpu"
    with pytest.raises(ValueError, match="torch sees no CUDA GPU"):
        task_device("cuda", None)
    # a cluster: the GPUs Ray counts decide
    assert task_device("auto", 0) == task_device("cpu", 4) == "cpu"
    assert task_device("auto", 2) == task_device("cuda", 1) == "cuda"
    with pytest.raises(ValueError, match="the Ray cluster has no GPU"):
        task_device("cuda", 0)
    with pytest.raises(ValueError, match="expected one of auto, cpu, cuda"):
        task_device("gpu", 1)


@pytest.mark.slow
def test_the_method_keeps_its_tensors_on_the_models_device():
    """The loops on the meta device (shapes only): a tensor made on the CPU and mixed in is an error there, as
    it would be on a GPU. CPU noise moved to the device, CPU text embeddings and a CPU clip are taken in."""
    from transfer.apply import apply_style_features
    from transfer.bundle import MethodBundle
    from transfer.denoiser import Denoiser, DenoiserConfig
    from transfer.learn import reconstruction_loss
    from transfer.lora import add_lora
    from transfer.sampling import generate
    from transfer.scheduler import DiffusionScheduler
    from transfer.style_config import ApplyConfig, LearnConfig

    meta = torch.device("meta")
    torch.manual_seed(0)
    prior = Denoiser(DenoiserConfig(width=32, layers=2, heads=2, ff=64, dropout=0.0)).eval().to(meta)
    style = copy.deepcopy(prior)
    add_lora(style, rank=4)
    assert {p.device for p in style.parameters()} == {meta}
    x, text, gen = torch.randn(130, FEATURES.dim), torch.randn(1, 384), torch.Generator().manual_seed(0)
    for mode in ("difference", "regenerate"):
        config = ApplyConfig(apply_mode=mode, delta_smoothing=1.0)
        out = apply_style_features(MethodBundle(prior), style, x.to(meta), LearnConfig(), config, neutral_text=text)
        assert out.device == meta and out.shape == x.shape
    assert generate(prior, DiffusionScheduler(), text, 40, 3, 2.5, gen).device == meta
    from transfer.sampling import TextToMotion

    bundle = MethodBundle(prior, torch.zeros(FEATURES.dim), torch.ones(FEATURES.dim))  # CPU normalisation, as loaded
    drawn = bundle.text_to_motion(text, 40, gen, TextToMotion(steps=3))  # the planted-feet guide on the device too
    assert drawn.device == meta and drawn.shape == (1, 40, FEATURES.dim)
    window = x[None, :80].to(meta)
    assert reconstruction_loss(style.train(), DiffusionScheduler(), window, window, LearnConfig(), gen).device == meta


@pytest.mark.slow
@pytest.mark.skipif(not (SHIPPED / "denoiser.safetensors").is_file(), reason="shipped weights not present")
def test_device_cpu_and_auto_give_the_default_result(no_gpu, tmp_path):
    from transfer.bundle import load_models
    from transfer.lora import add_lora, lora_state
    from transfer.style_file import Style
    from video2style.cli import main

    assert load_models("cpu") is load_models() is load_models("auto")  # one copy per resolved device
    torch.manual_seed(0)
    model = copy.deepcopy(load_models().prior)
    add_lora(model, rank=8)
    adapters = {k: v + 0.01 * torch.randn_like(v) for k, v in lora_state(model).items()}  # a style that changes things
    Style(adapters, {"style": "tiny", "rank": 8}).save(tmp_path / "tiny.v2s")
    outputs = []
    for device in ([], ["--device", "cpu"], ["--device", "auto"]):
        out = tmp_path / f"out{len(outputs)}"
        argv = ["apply", str(tmp_path / "tiny.v2s"), str(SAMPLES / "walk_prior.bvh"), "-o", str(out), "--no-preview"]
        assert main([*argv, "--neutralize", "never", *device]) == 0
        outputs.append((out / "walk_prior.bvh").read_bytes())
    assert outputs[0] == outputs[1] == outputs[2]
    assert outputs[0] != (SAMPLES / "walk_prior.bvh").read_bytes()


def test_park_et_al_keeps_its_tensors_on_the_models_device():
    """Park et al.'s inference on the meta device (shapes only), from CPU inputs: codes from noise and from a
    reference, and windowed generation, as a GPU would run them."""
    from park.infer import code_from_noise, code_from_reference, generate
    from park.networks import ParkConfig, ParkModel

    meta = torch.device("meta")
    torch.manual_seed(0)
    model = ParkModel(ParkConfig()).eval().to(meta)
    x = torch.randn(70, FEATURES.dim)
    codes = code_from_noise(model, model.config.domains[1], seed=3, n=2)
    assert codes.device == meta and codes.shape[0] == 2
    assert code_from_reference(model, x, model.config.domains[0]).device == meta
    out = generate(model, x.to(meta), codes[0])
    assert out.device == meta and out.shape == x.shape
