"""Rotations as unit quaternions ``(*, 4)`` in wxyz order, as small pure torch functions.

Every function works over any leading dimensions. Angles are radians. Matrices act on
column vectors (``v' = R @ v``); Euler orders follow BVH: ``order="ZXY"`` means
``R = Rz(a0) @ Rx(a1) @ Ry(a2)`` with ``angles[..., i]`` the angle about ``order[i]``.
"""
from __future__ import annotations

import torch
from kornia.geometry import conversions as _kc

_AXES = {"X": 0, "Y": 1, "Z": 2}


def _check_last(x: torch.Tensor, n: int, name: str) -> None:
    if not isinstance(x, torch.Tensor) or x.ndim == 0 or x.shape[-1] != n:
        shape = tuple(x.shape) if isinstance(x, torch.Tensor) else type(x).__name__
        raise ValueError(f"{name}: expected shape (*, {n}), got {shape}")


def identity(*shape: int, dtype=torch.float32, device=None) -> torch.Tensor:
    """Identity quaternions of shape ``(*shape, 4)``."""
    q = torch.zeros(*shape, 4, dtype=dtype, device=device)
    q[..., 0] = 1.0
    return q


def normalize(q: torch.Tensor, eps: float = 1e-8) -> torch.Tensor:
    """``(*, 4) -> (*, 4)`` unit length."""
    _check_last(q, 4, "quat.normalize")
    return q / q.norm(dim=-1, keepdim=True).clamp_min(eps)


def inv(q: torch.Tensor) -> torch.Tensor:
    """Inverse of unit quaternions ``(*, 4)`` (the conjugate)."""
    _check_last(q, 4, "quat.inv")
    return q * q.new_tensor([1.0, -1.0, -1.0, -1.0])


def mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Hamilton product ``a * b`` of ``(*, 4)`` quaternions (rotate by b, then by a)."""
    _check_last(a, 4, "quat.mul")
    _check_last(b, 4, "quat.mul")
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        dim=-1,
    )


def mul_vec(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors ``v (*, 3)`` by unit quaternions ``q (*, 4)``."""
    _check_last(q, 4, "quat.mul_vec")
    _check_last(v, 3, "quat.mul_vec")
    xyz, v = torch.broadcast_tensors(q[..., 1:], v)
    w = q[..., :1]
    t = 2.0 * torch.cross(xyz, v, dim=-1)
    return v + w * t + torch.cross(xyz, t, dim=-1)


def from_axis_angle(axis: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """Unit ``axis (*, 3)`` and ``angle (*)`` radians -> ``(*, 4)``."""
    _check_last(axis, 3, "quat.from_axis_angle")
    half = 0.5 * angle[..., None]
    return torch.cat([torch.cos(half), torch.sin(half) * axis], dim=-1)


def from_yaw(angle: torch.Tensor) -> torch.Tensor:
    """Rotation about +Y by ``angle (*)``: maps +Z to ``(sin a, 0, cos a)``. Returns ``(*, 4)``."""
    half = 0.5 * angle
    zero = torch.zeros_like(half)
    return torch.stack([torch.cos(half), zero, torch.sin(half), zero], dim=-1)


def to_matrix(q: torch.Tensor) -> torch.Tensor:
    """``(*, 4) -> (*, 3, 3)``."""
    _check_last(q, 4, "quat.to_matrix")
    return _kc.quaternion_to_rotation_matrix(normalize(q))


def from_matrix(m: torch.Tensor) -> torch.Tensor:
    """``(*, 3, 3) -> (*, 4)`` with ``w >= 0``."""
    if m.ndim < 2 or m.shape[-2:] != (3, 3):
        raise ValueError(f"quat.from_matrix: expected shape (*, 3, 3), got {tuple(m.shape)}")
    q = _kc.rotation_matrix_to_quaternion(m.contiguous())
    return normalize(torch.where(q[..., :1] < 0, -q, q))


def to_6d(q: torch.Tensor) -> torch.Tensor:
    """First two matrix columns (Zhou et al. 2019), ``(*, 4) -> (*, 6)``."""
    m = to_matrix(q)
    return torch.cat([m[..., :, 0], m[..., :, 1]], dim=-1)


def from_6d(d6: torch.Tensor) -> torch.Tensor:
    """Gram-Schmidt of two columns, ``(*, 6) -> (*, 4)``."""
    _check_last(d6, 6, "quat.from_6d")
    a = torch.nn.functional.normalize(d6[..., :3], dim=-1)
    b = d6[..., 3:] - (a * d6[..., 3:]).sum(-1, keepdim=True) * a
    b = torch.nn.functional.normalize(b, dim=-1)
    c = torch.cross(a, b, dim=-1)
    return from_matrix(torch.stack([a, b, c], dim=-1))


def _check_order(order: str) -> tuple[int, int, int]:
    if len(order) != 3 or sorted(order.upper()) != ["X", "Y", "Z"]:
        raise ValueError(f"expected an Euler order that is a permutation of XYZ, got {order!r}")
    return tuple(_AXES[c] for c in order.upper())


def from_euler(angles: torch.Tensor, order: str) -> torch.Tensor:
    """``angles (*, 3)`` radians, ``R = R[order[0]] @ R[order[1]] @ R[order[2]]`` -> ``(*, 4)``."""
    _check_last(angles, 3, "quat.from_euler")
    q = None
    for i, ax in enumerate(_check_order(order)):
        axis = angles.new_zeros(3)
        axis[ax] = 1.0
        qi = from_axis_angle(axis.expand(*angles.shape[:-1], 3), angles[..., i])
        q = qi if q is None else mul(q, qi)
    return q


def to_euler(q: torch.Tensor, order: str) -> torch.Tensor:
    """Inverse of :func:`from_euler`: ``(*, 4) -> (*, 3)`` radians, middle angle in [-pi/2, pi/2]."""
    i, j, k = _check_order(order)
    m = to_matrix(q)
    sign = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    b = torch.atan2(sign * m[..., i, k], torch.hypot(m[..., i, i], m[..., i, j]))
    a = torch.atan2(-sign * m[..., j, k], m[..., k, k])
    c = torch.atan2(-sign * m[..., i, j], m[..., i, i])
    # Gimbal lock: put the whole rotation into the first angle.
    locked = torch.hypot(m[..., i, i], m[..., i, j]) < 10 * torch.finfo(m.dtype).eps
    if locked.any():
        a_lock = torch.atan2(sign * m[..., k, j], m[..., j, j])
        a = torch.where(locked, a_lock, a)
        c = torch.where(locked, torch.zeros_like(c), c)
    return torch.stack([a, b, c], dim=-1)


def between(u: torch.Tensor, v: torch.Tensor, eps: float = 1e-8) -> torch.Tensor:
    """Shortest rotation taking direction ``u (*, 3)`` onto direction ``v (*, 3)``; ``(*, 4)``."""
    _check_last(u, 3, "quat.between")
    _check_last(v, 3, "quat.between")
    u = torch.nn.functional.normalize(u, dim=-1, eps=eps)
    v = torch.nn.functional.normalize(v, dim=-1, eps=eps)
    u, v = torch.broadcast_tensors(u, v)
    w = 1.0 + (u * v).sum(-1, keepdim=True)
    xyz = torch.cross(u, v, dim=-1)
    # Opposite vectors: rotate by pi about any axis perpendicular to u.
    opposite = w[..., 0] < eps
    if opposite.any():
        alt = torch.cross(u, u.new_tensor([1.0, 0.0, 0.0]).expand_as(u), dim=-1)
        alt2 = torch.cross(u, u.new_tensor([0.0, 1.0, 0.0]).expand_as(u), dim=-1)
        alt = torch.where(alt.norm(dim=-1, keepdim=True) < 1e-3, alt2, alt)
        xyz = torch.where(opposite[..., None], alt, xyz)
        w = torch.where(opposite[..., None], torch.zeros_like(w), w)
    return normalize(torch.cat([w, xyz], dim=-1))


def slerp(a: torch.Tensor, b: torch.Tensor, t: torch.Tensor | float) -> torch.Tensor:
    """Spherical interpolation ``(*, 4)``, ``t`` broadcastable to ``(*)``; takes the short way."""
    _check_last(a, 4, "quat.slerp")
    _check_last(b, 4, "quat.slerp")
    t = torch.as_tensor(t, dtype=a.dtype, device=a.device)
    dot = (a * b).sum(-1)
    b = torch.where(dot[..., None] < 0, -b, b)
    dot = dot.abs().clamp(max=1.0)
    theta = torch.acos(dot)
    sin = torch.sin(theta)
    small = sin < 1e-6
    safe = torch.where(small, torch.ones_like(sin), sin)
    wa = torch.where(small, 1.0 - t, torch.sin((1.0 - t) * theta) / safe)
    wb = torch.where(small, t, torch.sin(t * theta) / safe)
    return normalize(wa[..., None] * a + wb[..., None] * b)


def angle(q: torch.Tensor) -> torch.Tensor:
    """Rotation angle in [0, pi] of ``(*, 4)`` -> ``(*)``."""
    _check_last(q, 4, "quat.angle")
    return 2.0 * torch.atan2(q[..., 1:].norm(dim=-1), q[..., 0].abs())


def unroll(q: torch.Tensor, dim: int = 0) -> torch.Tensor:
    """Flip signs along ``dim`` (time) so consecutive quaternions lie in one hemisphere."""
    _check_last(q, 4, "quat.unroll")
    if q.shape[dim] < 2:
        return q.clone()
    q = q.movedim(dim, 0)
    flips = torch.where((q[1:] * q[:-1]).sum(-1) < 0, -1.0, 1.0).to(q.dtype)  # relative to the previous one
    sign = torch.cat([torch.ones_like(flips[:1]), torch.cumprod(flips, 0)])
    return (q * sign[..., None]).movedim(0, dim)


def fit_rotation(src: torch.Tensor, dst: torch.Tensor, weights: torch.Tensor | None = None) -> torch.Tensor:
    """Best rotation taking vectors ``src (*, N, 3)`` onto ``dst (*, N, 3)`` (Kabsch); ``(*, 4)``."""
    if src.shape != dst.shape or src.shape[-1] != 3 or src.ndim < 2:
        raise ValueError(f"quat.fit_rotation: expected matching (*, N, 3), got {tuple(src.shape)} and {tuple(dst.shape)}")
    w = torch.ones(src.shape[:-1], dtype=src.dtype) if weights is None else weights
    h = torch.einsum("...ni,...nj,...n->...ij", src.double(), dst.double(), w.double())
    u, _, vt = torch.linalg.svd(h)
    d = torch.sign(torch.det(vt.transpose(-1, -2) @ u.transpose(-1, -2)))
    diag = torch.diag_embed(torch.stack([torch.ones_like(d), torch.ones_like(d), d], dim=-1))
    r = vt.transpose(-1, -2) @ diag @ u.transpose(-1, -2)
    return from_matrix(r.to(src.dtype))
