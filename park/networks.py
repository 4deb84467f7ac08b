"""Park et al. 2021 networks on the canonical skeleton: stylizer G, style encoder E, mapping network F, discriminator D.

Everything is built from :class:`park.graph.STGCNBlock` (temporal kernel 3, spatial-configuration
partitions, leaky ReLU). Inputs and outputs are normalised features ``(B, T, D)``; the graph layout is
:func:`park.graph.features_to_graph` and its exact inverse.

Graph pooling (Park §5.2) averages consecutive joints within a body part, 21 -> 11 -> 5 nodes
(:data:`LEVEL1_GROUPS`, :data:`LEVEL2_GROUPS`), together with temporal average pooling by 2; unpooling
copies a group's value back to its members and upsamples time linearly. ``T`` must be a multiple of 4.

Differences from the appendix tables (all forced by reusing our ST-GCN block or variable lengths):
the block is post-activation (gcn -> IN -> act -> tcn -> IN/AdaIN -> + residual -> act) with AdaIN after
its second norm only; the skip connections add the encoder's features at each resolution to the
decoder's (the stem's through an affine-free instance norm, so they carry no per-channel style
statistics); E and D replace the ``T/4 x N/4`` convolution by a ``1 x N/4`` one averaged over time,
so they take any length; F's last layer goes straight into tanh (a ReLU before tanh would confine
codes to [0, 1)); D's two stacked linear heads are one.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import torch
from torch import nn
from torch.nn import functional as F

from mlcore.captions import STYLES
from motioncore.representation import FEATURES
from motioncore.skeleton import CANONICAL
from park.graph import (
    GRAPH_CHANNELS,
    STGCNBlock,
    canonical_adjacency,
    features_to_graph,
    graph_pool,
    graph_to_features,
    graph_unpool,
    partition_adjacency,
    partition_labels,
    pooled_graph,
    skeleton_edges,
)

_N = CANONICAL.skeleton.index
LEVEL1_GROUPS = [[_N(a) for a in g] for g in (
    ["Hips"], ["Spine", "Chest"], ["Neck", "Head"],
    ["Shoulder_L", "UpperArm_L"], ["LowerArm_L", "Hand_L"], ["Shoulder_R", "UpperArm_R"], ["LowerArm_R", "Hand_R"],
    ["UpperLeg_L", "LowerLeg_L"], ["Foot_L", "Toes_L"], ["UpperLeg_R", "LowerLeg_R"], ["Foot_R", "Toes_R"])]
"""21 joints -> 11 nodes: consecutive joints of each body part, pairwise."""
LEVEL2_GROUPS = [[0, 1, 2], [3, 4], [5, 6], [7, 8], [9, 10]]
"""11 -> 5 nodes: torso, left arm, right arm, left leg, right leg."""


def graph_levels() -> tuple[list[torch.Tensor], list[list[list[int]]]]:
    """Adjacencies ``(3, V, V)`` of the 21-, 11- and 5-node graphs and the two poolings between them."""
    edges0 = skeleton_edges()
    edges1 = pooled_graph(CANONICAL.num_joints, edges0, LEVEL1_GROUPS)
    edges2 = pooled_graph(len(LEVEL1_GROUPS), edges1, LEVEL2_GROUPS)
    a1 = partition_adjacency(partition_labels(len(LEVEL1_GROUPS), edges1, root=0))
    a2 = partition_adjacency(partition_labels(len(LEVEL2_GROUPS), edges2, root=0))
    return [canonical_adjacency(), a1, a2], [LEVEL1_GROUPS, LEVEL2_GROUPS]


@dataclass
class ParkConfig:
    domains: list[str] = field(default_factory=lambda: list(STYLES))
    channels: list[int] = field(default_factory=lambda: [32, 64, 128])  # paper: 64, 128, 256 (sized for CPU)
    style_dim: int = 64
    latent_dim: int = 16
    mapping_hidden: int = 512  # FC1a/FC1b 256 each, FC2 512, FC3 1024
    temporal_kernel: int = 3
    window: int = 64  # training clip length T; inference windows
    feature_dim: int = FEATURES.dim


def pool(x: torch.Tensor, groups: list[list[int]]) -> torch.Tensor:
    """Graph pooling plus temporal average pooling by 2: ``(B, C, T, V) -> (B, C, T/2, G)``."""
    return F.avg_pool2d(graph_pool(x, groups), (2, 1))


def unpool(x: torch.Tensor, groups: list[list[int]], num_nodes: int) -> torch.Tensor:
    """Graph unpooling plus linear temporal upsampling by 2: ``(B, C, T, G) -> (B, C, 2T, V)``."""
    x = graph_unpool(x, groups, num_nodes)
    return F.interpolate(x, scale_factor=(2, 1), mode="bilinear", align_corners=False)


def _block(c_in: int, c_out: int, a: torch.Tensor, cfg: ParkConfig, norm: str) -> STGCNBlock:
    return STGCNBlock(c_in, c_out, a, cfg.temporal_kernel, norm=norm, activation="leaky_relu")


def _check(x: torch.Tensor, cfg: ParkConfig) -> None:
    if x.ndim != 3 or x.shape[-1] != cfg.feature_dim or x.shape[1] % 4:
        raise ValueError(f"expected features (B, T, {cfg.feature_dim}) with T a multiple of 4, got {tuple(x.shape)}")


class Stylizer(nn.Module):
    """G: ``(x (B, T, D), s (B, style_dim)) -> (B, T, D)``; encoder IN blocks with pooling, decoder AdaIN blocks with unpooling."""

    def __init__(self, cfg: ParkConfig):
        super().__init__()
        self.cfg = cfg
        (a0, a1, _), self.groups = graph_levels()
        c0, c1, c2 = cfg.channels
        self.stem = nn.Conv2d(GRAPH_CHANNELS, c0, 1)
        self.enc = nn.ModuleList([_block(c0, c1, a0, cfg, "instance"), _block(c1, c2, a1, cfg, "instance")])
        self.dec = nn.ModuleList([_block(c2, c1, a1, cfg, "instance"), _block(c1, c0, a0, cfg, "instance")])
        self.adain = nn.ModuleList([nn.Linear(cfg.style_dim, 2 * c1), nn.Linear(cfg.style_dim, 2 * c0)])
        self.head = nn.Conv2d(c0, GRAPH_CHANNELS, 1)

    def forward(self, x: torch.Tensor, s: torch.Tensor) -> torch.Tensor:
        _check(x, self.cfg)
        h0 = self.stem(features_to_graph(x))
        h1 = pool(self.enc[0](h0), self.groups[0])  # (B, c1, T/2, 11)
        h = pool(self.enc[1](h1), self.groups[1])  # (B, c2, T/4, 5)
        h = self.dec[0](unpool(h, self.groups[1], len(LEVEL1_GROUPS)), style=self.adain[0](s)) + h1
        h = self.dec[1](unpool(h, self.groups[0], CANONICAL.num_joints), style=self.adain[1](s)) + F.instance_norm(h0)
        return graph_to_features(self.head(h))


class _Trunk(nn.Module):
    """Shared part of E and D: stem, two ST-GCN blocks with pooling, ``1 x 5`` conv, mean over time -> ``(B, c2)``."""

    def __init__(self, cfg: ParkConfig):
        super().__init__()
        self.cfg = cfg
        (a0, a1, _), self.groups = graph_levels()
        c0, c1, c2 = cfg.channels
        self.stem = nn.Conv2d(GRAPH_CHANNELS, c0, 1)
        self.blocks = nn.ModuleList([_block(c0, c1, a0, cfg, "none"), _block(c1, c2, a1, cfg, "none")])
        self.conv = nn.Conv2d(c2, c2, (1, len(LEVEL2_GROUPS)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        _check(x, self.cfg)
        h = self.stem(features_to_graph(x))
        for block, groups in zip(self.blocks, self.groups):
            h = pool(block(h), groups)
        h = self.conv(F.leaky_relu(h, 0.2)).mean(dim=(2, 3))
        return F.leaky_relu(h, 0.2)


class StyleEncoder(nn.Module):
    """E: ``(x (B, T, D), y (B,)) -> (B, style_dim)``, one linear branch per domain."""

    def __init__(self, cfg: ParkConfig):
        super().__init__()
        self.cfg = cfg
        self.trunk = _Trunk(cfg)
        self.heads = nn.Linear(cfg.channels[-1], cfg.style_dim * len(cfg.domains))

    def forward(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        out = self.heads(self.trunk(x)).view(x.shape[0], len(self.cfg.domains), self.cfg.style_dim)
        return out[torch.arange(x.shape[0], device=out.device), y]


class MappingNetwork(nn.Module):
    """F: ``(z (B, latent_dim), y (B,)) -> (B, style_dim)`` in (-1, 1)."""

    def __init__(self, cfg: ParkConfig):
        super().__init__()
        self.cfg = cfg
        h = cfg.mapping_hidden
        self.fc_z = nn.Sequential(nn.Linear(cfg.latent_dim, h // 2), nn.ReLU())
        self.fc_y = nn.Sequential(nn.Linear(len(cfg.domains), h // 2), nn.ReLU())
        self.shared = nn.Sequential(nn.Linear(h, h), nn.ReLU(), nn.Linear(h, 2 * h), nn.ReLU(),
                                    nn.Linear(2 * h, cfg.style_dim), nn.Tanh())

    def forward(self, z: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        onehot = F.one_hot(y, len(self.cfg.domains)).to(z.dtype)
        return self.shared(torch.cat([self.fc_z(z), self.fc_y(onehot)], dim=1))


class Discriminator(nn.Module):
    """D: ``(x (B, T, D), y (B,)) -> (B,)`` real/fake logit of domain ``y``'s branch."""

    def __init__(self, cfg: ParkConfig):
        super().__init__()
        self.cfg = cfg
        self.trunk = _Trunk(cfg)
        self.heads = nn.Linear(cfg.channels[-1], len(cfg.domains))

    def forward(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        return self.heads(self.trunk(x))[torch.arange(x.shape[0], device=x.device), y]


def he_init(module: nn.Module) -> None:
    """He (Kaiming normal, fan-in) weights and zero biases for every conv and linear layer (Park appendix A.2)."""
    for m in module.modules():
        if isinstance(m, (nn.Conv2d, nn.Linear)):
            nn.init.kaiming_normal_(m.weight, mode="fan_in", nonlinearity="relu")
            if m.bias is not None:
                nn.init.zeros_(m.bias)


class ParkModel(nn.Module):
    """What inference needs: G, E, F and the feature statistics (``mean``/``std``) the data was normalised with."""

    def __init__(self, cfg: ParkConfig):
        super().__init__()
        if cfg.feature_dim != FEATURES.dim:
            raise ValueError(f"ParkModel: built for {cfg.feature_dim}-d features, this code has {FEATURES.dim}")
        self.config = cfg
        self.g, self.e, self.f = Stylizer(cfg), StyleEncoder(cfg), MappingNetwork(cfg)
        self.register_buffer("mean", torch.zeros(cfg.feature_dim))
        self.register_buffer("std", torch.ones(cfg.feature_dim))
        he_init(self)

    def domain_index(self, domain: str) -> int:
        if domain not in self.config.domains:
            raise KeyError(f"{domain!r} is not a style domain of this model ({', '.join(self.config.domains)})")
        return self.config.domains.index(domain)

    def forward(self, x: torch.Tensor, s: torch.Tensor) -> torch.Tensor:
        return self.g(x, s)
