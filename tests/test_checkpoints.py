"""RunCheckpoint: the one checkpoint format of every trainer (key layout pinned so that runs resume across versions)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
import torch
from safetensors.torch import load_file

from mlcore.checkpoints import RunCheckpoint, optimizer_path
from mlcore.training import update_ema


@dataclass
class Config:
    width: int = 4
    lr: float = 0.01


def _run(tmp_path, named: bool):
    torch.manual_seed(0)
    a, b = torch.nn.Linear(3, 4), torch.nn.Linear(4, 2)
    opts = {"g": torch.optim.Adam(a.parameters()), "d": torch.optim.Adam(b.parameters())} if named else \
        {"": torch.optim.Adam([*a.parameters(), *b.parameters()])}
    names = {id(p): f"a.{n}" for n, p in a.named_parameters()} | {id(p): f"b.{n}" for n, p in b.named_parameters()}
    return a, b, opts, RunCheckpoint(tmp_path / "checkpoint.safetensors", Config(), {"model": a, "disc": b}, opts, names)


@pytest.mark.parametrize("named", [False, True])
def test_save_resume_round_trip_and_key_layout(tmp_path, named):
    a, b, opts, ckpt = _run(tmp_path, named)
    (b(a(torch.randn(5, 3))) ** 2).sum().backward()
    for opt in opts.values():
        opt.step()
    ckpt.step, ckpt.elapsed = 7, 12.5
    ckpt.save()
    keys = set(load_file(str(ckpt.path)))
    assert keys == {"model.weight", "model.bias", "disc.weight", "disc.bias"}
    assert optimizer_path(ckpt.path) == tmp_path / "checkpoint.optim.safetensors"
    moment_keys = set(load_file(str(optimizer_path(ckpt.path))))
    prefix = "g.opt.a.weight." if named else "opt.a.weight."
    assert {prefix + "exp_avg", prefix + "exp_avg_sq", prefix + "step"} <= moment_keys

    a2, _, opts2, ckpt2 = _run(tmp_path, named)
    with torch.no_grad():
        a2.weight.zero_()
    assert ckpt2.resume({"width": 4}) and (ckpt2.step, ckpt2.elapsed) == (7, 12.5)
    torch.testing.assert_close(a2.weight, a.weight)
    for o, o2 in zip(opts.values(), opts2.values()):
        for p, p2 in zip(o.param_groups[0]["params"], o2.param_groups[0]["params"]):
            torch.testing.assert_close(o2.state[p2]["exp_avg"], o.state[p]["exp_avg"])
    with pytest.raises(ValueError, match="cannot resume with different settings.*width: checkpoint 4 vs given 8"):
        ckpt2.resume({"width": 8})


def _trained(tmp_path):
    a, b, opts, ckpt = _run(tmp_path, named=True)
    (b(a(torch.randn(5, 3))) ** 2).sum().backward()
    for opt in opts.values():
        opt.step()
    ckpt.step = 3
    ckpt.save()
    return a, opts, ckpt


def test_a_one_file_checkpoint_of_older_versions_still_resumes(tmp_path):
    from safetensors import safe_open
    from safetensors.torch import save_file

    _, opts, ckpt = _trained(tmp_path)
    with safe_open(str(ckpt.path), framework="pt") as f:
        meta = f.metadata()
    merged = load_file(str(ckpt.path)) | load_file(str(optimizer_path(ckpt.path)))
    save_file(merged, str(ckpt.path), metadata=meta)
    optimizer_path(ckpt.path).unlink()
    _, _, opts2, ckpt2 = _run(tmp_path, named=True)
    assert ckpt2.resume({}) and ckpt2.step == 3
    p, p2 = opts["g"].param_groups[0]["params"][0], opts2["g"].param_groups[0]["params"][0]
    torch.testing.assert_close(opts2["g"].state[p2]["exp_avg"], opts["g"].state[p]["exp_avg"])


def test_moments_of_another_step_or_none_are_refused(tmp_path):
    from safetensors.torch import save_file

    _, _, ckpt = _trained(tmp_path)
    moments = load_file(str(optimizer_path(ckpt.path)))
    save_file(moments, str(optimizer_path(ckpt.path)), metadata={"step": "2"})
    with pytest.raises(ValueError, match="expected the moments of step 3, got step 2"):
        _run(tmp_path, named=True)[3].resume({})
    optimizer_path(ckpt.path).unlink()
    with pytest.raises(ValueError, match="checkpoint.optim.safetensors: missing"):
        _run(tmp_path, named=True)[3].resume({})


def test_no_checkpoint_means_a_fresh_run(tmp_path):
    *_, ckpt = _run(tmp_path / "new", named=False)
    assert not ckpt.resume({}) and ckpt.step == 0


def test_update_ema_warms_up_then_follows_decay():
    ema, model = torch.nn.Linear(1, 1, bias=False), torch.nn.Linear(1, 1, bias=False)
    with torch.no_grad():
        ema.weight.fill_(0.0)
        model.weight.fill_(1.0)
    update_ema(ema, model, decay=0.999, step=0)  # d = min(0.999, 1/10)
    assert float(ema.weight) == pytest.approx(0.9)
    update_ema(ema, model, decay=0.5, step=1000)  # d = 0.5
    assert float(ema.weight) == pytest.approx(0.95)


def test_lr_factor_warms_up_holds_then_decays_to_its_floor():
    from mlcore.training import lr_factor

    assert lr_factor(0, warmup=4) == 0.25
    assert lr_factor(3, warmup=4) == 1.0
    assert lr_factor(10_000, warmup=4) == 1.0  # no decay asked for: constant
    kw = {"warmup": 4, "decay_start": 100, "decay_steps": 10, "final": 0.1}
    assert lr_factor(99, **kw) == 1.0
    assert lr_factor(100, **kw) == 1.0
    assert abs(lr_factor(105, **kw) - 0.55) < 1e-12
    assert abs(lr_factor(110, **kw) - 0.1) < 1e-12
    assert abs(lr_factor(10_000, **kw) - 0.1) < 1e-12
