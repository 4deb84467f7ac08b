"""Park et al. 2021 training objectives (eq. 7-12), all weights 1 by default.

A *style source* is either noise ``z`` (the mapping network F: latent-guided) or a reference motion
(the style encoder E: reference-guided); training alternates the two (appendix A.2). Reconstruction
terms are L1 means over the normalised features.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch
from torch.nn import functional as F

from park.networks import Discriminator, ParkModel


@dataclass
class LossWeights:
    adv: float = 1.0
    cyc: float = 1.0
    id: float = 1.0
    sty: float = 1.0
    ds: float = 1.0
    r1: float = 1.0  # R1 penalty on real samples: not in the paper's text, but in the authors' code (lambda_reg 1) and StarGAN v2; 0 = off


def adversarial(logits: torch.Tensor, real: bool) -> torch.Tensor:
    """Eq. 7 as binary cross-entropy on the domain branch's logits."""
    return F.binary_cross_entropy_with_logits(logits, torch.full_like(logits, float(real)))


def style_code(model: ParkModel, y: torch.Tensor, z: torch.Tensor | None = None, ref: torch.Tensor | None = None) -> torch.Tensor:
    """``F(z, y)`` when ``z`` is given, else ``E_y(ref)``."""
    if (z is None) == (ref is None):
        raise ValueError("style_code: give exactly one of z (noise) and ref (reference motion)")
    return model.f(z, y) if z is not None else model.e(ref, y)


def r1_penalty(d_real: torch.Tensor, x_real: torch.Tensor) -> torch.Tensor:
    grad, = torch.autograd.grad(d_real.sum(), x_real, create_graph=True)
    return 0.5 * grad.pow(2).flatten(1).sum(1).mean()


def d_loss(model: ParkModel, disc: Discriminator, x: torch.Tensor, y_org: torch.Tensor, y_trg: torch.Tensor,
           w: LossWeights, z: torch.Tensor | None = None, ref: torch.Tensor | None = None) -> tuple[torch.Tensor, dict]:
    """Discriminator side of eq. 7: real ``x`` of ``y_org`` vs ``G(x, s)`` with ``s`` of ``y_trg``."""
    if w.r1 > 0:
        x = x.detach().requires_grad_(True)
    real = disc(x, y_org)
    loss_real = adversarial(real, True)
    with torch.no_grad():
        fake = model.g(x, style_code(model, y_trg, z, ref))
    loss_fake = adversarial(disc(fake, y_trg), False)
    loss = w.adv * (loss_real + loss_fake)
    logs = {"d_real": loss_real.item(), "d_fake": loss_fake.item()}
    if w.r1 > 0:
        reg = r1_penalty(real, x)
        loss = loss + w.r1 * reg
        logs["r1"] = reg.item()
    return loss, logs


def g_loss(model: ParkModel, disc: Discriminator, x: torch.Tensor, y_org: torch.Tensor, y_trg: torch.Tensor,
           w: LossWeights, z: tuple[torch.Tensor, torch.Tensor] | None = None,
           ref: tuple[torch.Tensor, torch.Tensor] | None = None) -> tuple[torch.Tensor, dict]:
    """Eq. 12 for G (and F or E): adversarial + cycle + identity + style reconstruction - diversity.

    ``z`` or ``ref`` is a pair of style sources of the target domain; the diversity term (eq. 11)
    compares the outputs for the two.
    """
    z1, z2 = z if z is not None else (None, None)
    r1, r2 = ref if ref is not None else (None, None)
    s_trg = style_code(model, y_trg, z1, r1)
    fake = model.g(x, s_trg)
    adv = adversarial(disc(fake, y_trg), True)
    sty = (model.e(fake, y_trg) - s_trg).abs().mean()  # eq. 10
    with torch.no_grad():
        fake2 = model.g(x, style_code(model, y_trg, z2, r2))
    ds = (fake - fake2).abs().mean()  # eq. 11, maximised
    s_org = model.e(x, y_org)
    cyc = (model.g(fake, s_org) - x).abs().mean()  # eq. 8
    idt = (model.g(x, s_org) - x).abs().mean()  # eq. 9
    loss = w.adv * adv + w.cyc * cyc + w.id * idt + w.sty * sty - w.ds * ds
    return loss, {"g_adv": adv.item(), "cyc": cyc.item(), "id": idt.item(), "sty": sty.item(), "ds": ds.item()}
