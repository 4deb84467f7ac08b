"""Training Park et al.'s stylizer on the Bandai-2 train split (7 style domains): a small resumable GAN loop.

Each iteration is one discriminator step and one generator step; even iterations take the target
style code from noise through F (G, F and E are updated), odd ones from a reference motion through
E (G is updated), as in StarGAN v2, which Park et al. follow. Clips are random ``window``-frame
windows of the train clips (mirrored copies included), source clips drawn class-balanced over the
domains; clips shorter than the window are padded with their first and last frames (Park §4),
standing still. The checkpoint (``out_dir/checkpoint.safetensors``) holds G/E/F, their EMA copies,
D and all four optimizers' moments; ``log.csv`` gets one row per iteration. The exported weights
(EMA G, E, F + feature statistics; D is not shipped) go to ``weights_path`` with a JSON card.
"""
from __future__ import annotations

import copy
import dataclasses
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import torch

from mlcore.checkpoints import RunCheckpoint, save_model
from mlcore.dataset import MotionDataset, labelled_clips
from mlcore.device import resolve_device
from mlcore.shipped import weights_dir
from mlcore.training import train_loop, update_ema
from motioncore.representation import FEATURES
from park.losses import LossWeights, d_loss, g_loss
from park.networks import Discriminator, ParkConfig, ParkModel, he_init


def default_weights() -> Path:
    return weights_dir() / "park_stylizer.safetensors"


@dataclass
class ParkTrainConfig:
    """Defaults are sized for a CPU budget; :meth:`paper` gives the appendix's optimiser settings."""

    channels: list[int] = field(default_factory=lambda: [32, 64, 128])
    window: int = 64
    batch_size: int = 8
    lr_g: float = 1e-4
    lr_d: float = 1e-4
    lr_e: float = 1e-4
    lr_f: float = 1e-5
    betas: list[float] = field(default_factory=lambda: [0.0, 0.99])
    weight_decay: float = 1e-4
    weights: LossWeights = field(default_factory=LossWeights)
    ds_decay_steps: int = 100_000  # lambda_ds falls linearly to 0 over this many steps (authors' code: ds_iter); 0 = constant
    ema: float = 0.999
    seed: int = 0

    @classmethod
    def paper(cls, **kw) -> ParkTrainConfig:
        """Appendix A.2 as printed: Adam (0.99, 0.999); lr 1e-4 G, 1e-6 D and E, 1e-5 F (the authors' code agrees on the lrs)."""
        return cls(**{"lr_d": 1e-6, "lr_e": 1e-6, "betas": [0.99, 0.999], "channels": [64, 128, 256], **kw})

    def model_config(self) -> ParkConfig:
        return ParkConfig(channels=list(self.channels), window=self.window)


class WindowSampler:
    """Random normalised training windows of labelled clips: ``sample(y) -> x (len(y), window, D)``."""

    def __init__(self, data: MotionDataset, idx: list[int], labels: list[int], num_domains: int, window: int):
        self.data, self.window = data, window
        self.by_class = [[i for i, c in zip(idx, labels) if c == k] for k in range(num_domains)]
        self.present = [k for k, m in enumerate(self.by_class) if m]
        if not self.present:
            raise ValueError("WindowSampler: no labelled clips")

    def domains(self, n: int, gen: torch.Generator) -> torch.Tensor:
        return torch.tensor([self.present[int(k)] for k in torch.randint(len(self.present), (n,), generator=gen)])

    def sample(self, y: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
        out = torch.empty(len(y), self.window, self.data.features.shape[1])
        for b, k in enumerate(y.tolist()):
            members = self.by_class[k]
            r = self.data.records[members[int(torch.randint(len(members), (1,), generator=gen))]]
            clip = self.data.features[r.start:r.start + r.length]
            if r.length >= self.window:
                s = int(torch.randint(r.length - self.window + 1, (1,), generator=gen))
                raw = clip[s:s + self.window]
            else:
                before = int(torch.randint(self.window - r.length + 1, (1,), generator=gen))
                after = self.window - r.length - before
                still = lambda f, n: f.clone().expand(n, -1).clone().index_fill_(1, _root_vel_index(), 0.0)
                raw = torch.cat([still(clip[:1], before), clip, still(clip[-1:], after)])
            out[b] = self.data.standardize(raw)
        return out


def _root_vel_index() -> torch.Tensor:
    return torch.tensor(list(range(FEATURES.root_rvel.start, FEATURES.root_rvel.stop))
                        + list(range(FEATURES.root_lvel.start, FEATURES.root_lvel.stop)))


class ParkTraining:
    """Nets, optimisers and checkpointing of one run."""

    def __init__(self, config: ParkTrainConfig, out_dir: Path, device: str | torch.device = "cpu"):
        self.config, self.out_dir = config, Path(out_dir)
        torch.manual_seed(config.seed)
        self.device = resolve_device(device)
        self.model = ParkModel(config.model_config())  # made on the CPU (the same seeded weights anywhere), then moved
        self.disc = Discriminator(self.model.config)
        he_init(self.disc)
        self.model.to(self.device)
        self.disc.to(self.device)
        self.ema = copy.deepcopy(self.model).eval().requires_grad_(False)
        adam = lambda mod, lr: torch.optim.Adam(mod.parameters(), lr, betas=tuple(config.betas), weight_decay=config.weight_decay)
        self.opts = {"g": adam(self.model.g, config.lr_g), "e": adam(self.model.e, config.lr_e),
                     "f": adam(self.model.f, config.lr_f), "d": adam(self.disc, config.lr_d)}
        names = {id(p): f"model.{n}" for n, p in self.model.named_parameters()}
        names.update({id(p): f"disc.{n}" for n, p in self.disc.named_parameters()})
        self.checkpoint = RunCheckpoint(self.out_dir / "checkpoint.safetensors", config,
                                        {"model": self.model, "ema": self.ema, "disc": self.disc}, self.opts, names)

    @property
    def step(self) -> int:
        return self.checkpoint.step

    def init_from(self, weights_path: Path) -> None:
        """Start G/E/F (and their EMA copies) from exported weights; the widths must match the config."""
        from park.infer import load_park

        exported = load_park(weights_path)
        if list(exported.config.channels) != list(self.model.config.channels):
            raise ValueError(f"{weights_path}: expected channels {self.model.config.channels}, got {exported.config.channels}")
        self.model.load_state_dict(exported.state_dict())
        self.ema.load_state_dict(exported.state_dict())

    def iteration(self, sampler: WindowSampler, gen: torch.Generator) -> dict:
        """One D step and one G step; latent-guided on even steps, reference-guided on odd ones."""
        w, n = self.config.weights, self.config.batch_size
        if self.config.ds_decay_steps > 0:
            w = dataclasses.replace(w, ds=w.ds * max(0.0, 1 - self.step / self.config.ds_decay_steps))
        dev = self.device  # batches and noise are drawn on the CPU from ``gen``, then moved
        y_org = sampler.domains(n, gen)
        x = sampler.sample(y_org, gen).to(dev)
        y_trg = sampler.domains(n, gen)
        latent = self.step % 2 == 0
        if latent:
            src = {"z": (torch.randn(n, self.model.config.latent_dim, generator=gen).to(dev),
                         torch.randn(n, self.model.config.latent_dim, generator=gen).to(dev))}
        else:
            src = {"ref": (sampler.sample(y_trg, gen).to(dev), sampler.sample(y_trg, gen).to(dev))}
        y_org, y_trg = y_org.to(dev), y_trg.to(dev)
        loss, logs = d_loss(self.model, self.disc, x, y_org, y_trg, w, **{k: v[0] for k, v in src.items()})
        self.opts["d"].zero_grad(set_to_none=True)
        loss.backward()
        self.opts["d"].step()
        self.disc.requires_grad_(False)  # D is a fixed critic in the G step
        loss, g_logs = g_loss(self.model, self.disc, x, y_org, y_trg, w, **src)
        for o in self.opts.values():
            o.zero_grad(set_to_none=True)
        loss.backward()
        self.disc.requires_grad_(True)
        for name in ("g", "f", "e") if latent else ("g",):
            self.opts[name].step()
        self.checkpoint.step += 1
        update_ema(self.ema, self.model, self.config.ema, self.step)
        return {"mode": "latent" if latent else "reference", "g_total": loss.item(), **logs, **g_logs}


def train_park(data_dir: Path, out_dir: Path, config: ParkTrainConfig | None = None, max_minutes: float = 10.0,
               max_steps: int = 100_000, weights_path: Path | None = None, explicit: dict | None = None,
               checkpoint_minutes: float = 5.0, progress: bool = True, init_path: Path | None = None,
               device: str = "cpu") -> dict:
    """Train (or resume) on the Bandai-2 train split until ``max_steps`` or ``max_minutes`` (this call).

    ``device``: auto, cpu or cuda (:func:`mlcore.device.resolve_device`); the exported weights are CPU tensors.
    ``init_path``: exported weights (G/E/F) to start a *new* run from (fine-tuning, e.g. with another
    ``weights.ds``); D starts fresh. Ignored when ``out_dir`` already holds a checkpoint.

    Exports the EMA G/E/F to ``weights_path`` (default ``mlcore/weights/park_stylizer.safetensors``)
    with a JSON model card, and returns the card. Threads: set ``torch.set_num_threads`` before calling.
    """
    config = config or ParkTrainConfig()
    weights_path = Path(weights_path) if weights_path is not None else default_weights()
    run = ParkTraining(config, out_dir, device)
    init_note = None
    if not run.checkpoint.resume(explicit or {}) and init_path is not None:
        run.init_from(Path(init_path))
        init_note = f"fine-tuned from {Path(init_path).name}"
    data, idx, labels = labelled_clips(Path(data_dir), "train", "style")
    if not idx:
        raise ValueError(f"{data_dir}: no Bandai-2 train clips with style labels")
    run.model.mean.copy_(data.mean)
    run.model.std.copy_(data.std)
    run.ema.mean.copy_(data.mean)
    run.ema.std.copy_(data.std)
    sampler = WindowSampler(data, idx, labels, len(run.model.config.domains), config.window)
    gen = torch.Generator().manual_seed(config.seed * 1000003 + run.step)
    torch.manual_seed(config.seed * 1000003 + run.step)

    fields = ["step", "time_s", "mode", "g_total", "d_real", "d_fake", "r1", "g_adv", "cyc", "id", "sty", "ds"]
    run.model.train()
    train_loop(run.checkpoint, lambda: run.iteration(sampler, gen), run.out_dir / "log.csv", max_steps, max_minutes,
               checkpoint_minutes, progress, fields,
               postfix=lambda row: {k: f"{row[k]:.3f}" for k in ("d_real", "d_fake", "g_adv", "cyc", "sty", "ds")})
    card = {
        "model": "video2style Park et al. 2021 stylizer (ST-GCN GAN): G, E, F (EMA weights); D not shipped",
        "domains": list(run.model.config.domains),
        "data": f"Bandai-Namco-Research-Motiondataset-2, train split of {Path(data_dir).name} ({len(idx)} clips with "
                f"mirrored copies), 20 fps, random {config.window}-frame windows",
        "licence": "CC BY-NC 4.0, inherited from the Bandai-Namco training data",
        "steps": run.step,
        **({"initialised_from": init_note} if init_note else {}),
        "batch_size": config.batch_size,
        "wall_time_minutes": round(run.checkpoint.elapsed / 60, 1),
        "torch_threads": torch.get_num_threads(),
        "machine": "2 CPU cores",
        "date": time.strftime("%Y-%m-%d"),
        "train_config": asdict(config),
        "model_config": asdict(run.ema.config),
        "parameters": sum(p.numel() for p in run.ema.parameters()),
    }
    save_model(run.ema, run.ema.config, weights_path, card)
    return card
