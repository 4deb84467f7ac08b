"""Joint positions -> joint rotations on a fixed skeleton (constant bone lengths).

:func:`fit_positions` solves the rotations top-down so that every bone points from its
joint's fitted position toward the target position of its child:

* joints with several children (the canonical Hips and Chest) take the best rotation of
  their child vectors onto the measured ones (Kabsch, :func:`motioncore.quat.fit_rotation`);
* joints with one child swing the shortest way from a *reference local rotation* onto the
  measured direction (:func:`motioncore.quat.between`), so the twist about the bone, which
  positions cannot tell, is the reference's;
* the upper segments of the knees and elbows (:data:`HINGES`) are then twisted about their
  bone so that the lower segment bends about the hinge axis, as in the data;
* leaves (Head, Hands, Toes) keep the reference local rotation unless given one.

The reference pose (:data:`REFERENCE_LOCAL`) is the mean local rotation of each joint over
the non-mirrored Bandai-Namco-2 training clips on the canonical skeleton. Its retargeted
joints carry fixed twists (Spine +90 deg about Y, Chest -90 deg, UpperLeg_R ~166 deg, ...);
fitting around them keeps the rotation features of fitted motions in the same convention as
the training data (a plain shortest-arc fit would reproduce the positions but not those
features). :func:`reference_local_rotations` recomputes the table from motions.

With targets that come from FK of the same skeleton the positions are reproduced to float
precision (see ``tests/lifting/test_pipeline_fit.py``).
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import torch

from motioncore import quat
from motioncore.kinematics import fk, to_local
from motioncore.motion import Motion
from motioncore.skeleton import CANONICAL, CanonicalSpec, Skeleton

CHUNK = 5_000  # frames solved at a time by fit_positions: bounds the float64 temporaries of a long take

# Mean local rotation (w, x, y, z) per canonical joint; Hips (the root) is unused.
# From reference_local_rotations() over the non-mirrored bandai2 clips of the training split.
REFERENCE_LOCAL: dict[str, tuple[float, float, float, float]] = {
    "Hips": (1.0, 0.0, 0.0, 0.0),
    "Spine": (0.7094, 0.0146, 0.7043, 0.0225),
    "Chest": (0.7011, 0.0257, -0.7114, 0.0417),
    "Neck": (0.9991, 0.0415, -0.0115, 0.0032),
    "Head": (1.0, -0.0016, -0.0077, 0.0037),
    "Shoulder_L": (0.6982, -0.6973, 0.115, 0.1142),
    "UpperArm_L": (0.8565, -0.055, 0.4669, -0.2129),
    "LowerArm_L": (0.9036, 0.1383, -0.0653, -0.4001),
    "Hand_L": (0.9876, 0.0396, -0.1518, 0.0111),
    "Shoulder_R": (0.702, 0.6986, -0.0768, 0.1151),
    "UpperArm_R": (0.8619, -0.0184, 0.4563, -0.2206),
    "LowerArm_R": (0.9291, 0.0168, -0.0118, -0.3693),
    "Hand_R": (0.983, 0.0546, -0.173, -0.0285),
    "UpperLeg_L": (0.9943, -0.0613, 0.0722, 0.049),
    "LowerLeg_L": (0.9633, 0.2684, -0.0007, -0.0002),
    "Foot_L": (0.9987, 0.0299, -0.0402, -0.0046),
    "Toes_L": (0.9896, -0.1439, 0.0, -0.0005),
    "UpperLeg_R": (0.1212, 0.0147, 0.9913, -0.0497),
    "LowerLeg_R": (0.9671, -0.2544, 0.0002, 0.0),
    "Foot_R": (0.3905, 0.9192, 0.034, -0.0372),
    "Toes_R": (0.9889, 0.1485, -0.0004, 0.0005),
}

# Upper segment -> bend normal in its local frame: normalize(bone axis x lower-segment direction)
# whenever the limb is bent. In the Bandai data these are exact hinges (median deviation < 0.001 deg).
HINGES: dict[str, tuple[float, float, float]] = {
    "UpperLeg_L": (1.0, 0.0, 0.0),
    "UpperLeg_R": (-1.0, 0.0, 0.0),
    "UpperArm_L": (0.0, 0.0, -1.0),
    "UpperArm_R": (0.0, 0.0, -1.0),
}

# The hinge twist fades in between these bend angles (the plane of a straight limb is unknown).
HINGE_BEND_DEG = (8.0, 25.0)


def reference_local_rotations(motions: Iterable[Motion], skeleton: Skeleton = CANONICAL.skeleton) -> torch.Tensor:
    """Mean local rotation ``(J, 4)`` of each joint over all frames of ``motions`` (the principal
    eigenvector of the summed outer products, sign-independent)."""
    acc = torch.zeros(skeleton.num_joints, 4, 4, dtype=torch.float64)
    for m in motions:
        q = m.lrot.double()
        acc += torch.einsum("tji,tjk->jik", q, q)
    if not acc.abs().sum() > 0:
        raise ValueError("reference_local_rotations: expected at least one frame")
    mean = torch.linalg.eigh(acc)[1][..., -1]
    return (mean * torch.sign(mean[:, :1] + 1e-12)).float()


def default_reference(skeleton: Skeleton = CANONICAL.skeleton) -> torch.Tensor:
    """:data:`REFERENCE_LOCAL` as ``(J, 4)`` for the canonical skeleton, identity for other joints."""
    ref = quat.identity(skeleton.num_joints)
    for j, name in enumerate(skeleton.names):
        if name in REFERENCE_LOCAL:
            ref[j] = torch.tensor(REFERENCE_LOCAL[name])
    return quat.normalize(ref)


def _smoothstep(x: torch.Tensor, lo: float, hi: float) -> torch.Tensor:
    t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _unit(v: torch.Tensor) -> torch.Tensor:
    return torch.nn.functional.normalize(v, dim=-1, eps=1e-9)


def fit_positions(
    targets: torch.Tensor,
    fps: float,
    spec: CanonicalSpec = CANONICAL,
    reference: torch.Tensor | None = None,
    anchors: Mapping[int, Sequence[int]] | None = None,
    hinges: Mapping[str, Sequence[float]] | None = None,
    leaf_rotations: Mapping[int, torch.Tensor] | None = None,
    relative: bool = True,
) -> Motion:
    """Target joint positions ``(T, J, 3)`` metres -> a :class:`Motion` on ``spec.skeleton``.

    ``reference (J, 4)``: local rotations the single-child joints swing from (default
    :func:`default_reference`). ``anchors``: for joints with several children, the descendant
    joints whose directions the Kabsch fit matches (default: the children); descendants below a
    child are placed with the reference rotations. ``hinges``: upper segment name -> bend normal
    (default :data:`HINGES`; ``{}`` turns the hinge twist off). ``leaf_rotations``: joint index ->
    global rotations ``(T, 4)`` for leaves (e.g. a head frame from face landmarks); other leaves
    keep the reference local rotation. The root is placed at ``targets[:, 0]``.

    ``relative=True`` points each bone along the direction between the *targets* of its two
    joints (the measured angles are kept where the target proportions differ from the
    skeleton's); ``False`` points it from the fitted joint toward the child's target (end joints
    land nearer their targets). Targets from FK of the same skeleton give the same result.
    Non-finite targets are not allowed (interpolate gaps first).
    """
    sk = spec.skeleton
    j_count = sk.num_joints
    if targets.ndim != 3 or targets.shape[1:] != (j_count, 3) or targets.shape[0] < 1:
        raise ValueError(f"fit_positions: expected targets (T>=1, {j_count}, 3), got {tuple(targets.shape)}")
    if not torch.isfinite(targets).all():
        raise ValueError("fit_positions: targets contain NaN or inf; interpolate missing frames first")
    t_count = targets.shape[0]
    leaf_rotations = leaf_rotations or {}
    g_all = torch.empty(t_count, j_count, 4, dtype=torch.float64)
    for a in range(0, t_count, CHUNK):  # each frame is solved on its own: a long take a chunk at a time
        g_all[a:a + CHUNK] = _global_rotations(targets[a:a + CHUNK].double(), sk, reference, anchors, hinges,
                                               {j: q[a:a + CHUNK] for j, q in leaf_rotations.items()}, relative)
    g_all = quat.unroll(g_all, dim=0)  # signs continuous over the whole clip, then each frame made local
    lrot = torch.empty_like(g_all)
    for a in range(0, t_count, CHUNK):
        lrot[a:a + CHUNK] = to_local(g_all[a:a + CHUNK], sk.parents)
    del g_all
    lrot = quat.unroll(lrot, dim=0).float()
    lpos = sk.offsets.expand(t_count, -1, -1).clone()  # float32 as the double round trip gave: the offsets, the root
    lpos[:, 0] = targets[:, 0]
    return Motion(sk, lrot, lpos, fps)


def _global_rotations(x: torch.Tensor, sk: Skeleton, reference, anchors, hinges, leaf_rotations,
                      relative: bool) -> torch.Tensor:
    """:func:`fit_positions`' per-frame solve: float64 targets ``x (T, J, 3)`` -> global rotations ``(T, J, 4)``."""
    j_count = sk.num_joints
    t_count = x.shape[0]
    ref = (default_reference(sk) if reference is None else reference).double()
    offsets = sk.offsets.double()
    hinges = HINGES if hinges is None else hinges
    hinge_idx = {sk.index(n): torch.tensor(a, dtype=torch.float64) for n, a in hinges.items() if n in sk.names}
    children = [sk.children(j) for j in range(j_count)]
    anchors = dict(anchors or {})

    grot: list[torch.Tensor | None] = [None] * j_count
    gpos: list[torch.Tensor | None] = [None] * j_count
    gpos[0] = x[:, 0]
    for j in range(j_count):
        kids = children[j]
        parent = sk.parents[j]
        base = ref[j].expand(t_count, 4) if parent < 0 else quat.mul(grot[parent], ref[j].expand(t_count, 4))
        if len(kids) > 1 or (parent < 0 and kids):
            use = list(anchors.get(j, kids))
            src = torch.stack([_reference_vector(sk, ref, j, d, offsets) for d in use])  # (N, 3) in j's frame
            origin = x[:, j] if relative else gpos[j]
            dst = torch.stack([x[:, d] - origin for d in use], dim=1)  # (T, N, 3)
            dst = _unit(dst) * src.norm(dim=-1)[None, :, None]
            g = quat.fit_rotation(src.expand(t_count, -1, -1), dst)
        elif len(kids) == 1:
            c = kids[0]
            cur = quat.mul_vec(base, offsets[c].expand(t_count, 3))
            g = quat.mul(quat.between(cur, x[:, c] - (x[:, j] if relative else gpos[j])), base)
            if j in hinge_idx and len(children[c]) == 1:
                gc = children[c][0]
                lower = x[:, gc] - (x[:, c] if relative else gpos[j] + quat.mul_vec(g, offsets[c].expand(t_count, 3)))
                g = _hinge_twist(g, offsets[c], lower, hinge_idx[j])
        else:
            g = leaf_rotations[j].double() if j in leaf_rotations else base
        grot[j] = quat.normalize(g)
        for c in kids:
            gpos[c] = gpos[j] + quat.mul_vec(grot[j], offsets[c].expand(t_count, 3))
    return torch.stack(grot, dim=1)


def _reference_vector(sk: Skeleton, ref: torch.Tensor, j: int, d: int, offsets: torch.Tensor) -> torch.Tensor:
    """Position of descendant ``d`` in joint ``j``'s frame with the reference rotations in between."""
    chain = []
    k = d
    while k != j:
        if k < 0:
            raise ValueError(f"fit_positions: anchor {sk.names[d]} is not below {sk.names[j]}")
        chain.append(k)
        k = sk.parents[k]
    rot = quat.identity(dtype=torch.float64)
    pos = torch.zeros(3, dtype=torch.float64)
    for k in reversed(chain):
        pos = pos + quat.mul_vec(rot, offsets[k])
        rot = quat.mul(rot, ref[k])
    return pos


def _hinge_twist(g: torch.Tensor, bone: torch.Tensor, lower: torch.Tensor, normal: torch.Tensor) -> torch.Tensor:
    """Twist ``g (T, 4)`` of an upper segment about its ``bone`` offset so that the lower segment,
    pointing along ``lower (T, 3)`` (global), bends about ``normal`` (local)."""
    t_count = g.shape[0]
    axis = _unit(bone)
    u = quat.mul_vec(quat.inv(g), _unit(lower))  # lower direction, local
    u_perp = u - (u @ axis)[:, None] * axis
    bend = torch.asin(u_perp.norm(dim=-1).clamp(max=1.0))
    bend = torch.where((u @ axis) < 0, math.pi - bend, bend)  # folded back past 90 deg
    want = torch.cross(normal.expand(t_count, 3), axis.expand(t_count, 3), dim=-1)  # bend direction
    psi = torch.atan2((axis * torch.cross(want, u_perp, dim=-1)).sum(-1), (want * u_perp).sum(-1))
    lo, hi = HINGE_BEND_DEG
    w = _smoothstep(torch.rad2deg(bend), lo, hi)
    twist = quat.from_axis_angle(axis.expand(t_count, 3), w * psi)
    return quat.mul(g, twist)


def decode_via_positions(feats: torch.Tensor, fps: float, start_yaw: float = 0.0,
                         start_xz: tuple[float, float] = (0.0, 0.0), spec: CanonicalSpec = CANONICAL) -> Motion:
    """Features ``(T, D)`` -> :class:`Motion` from their *position* channels (root path integrated from
    ``start_*``), rotations solved by :func:`fit_positions`; for models whose rotation channels are
    less reliable than their positions. ``representation.decode`` uses the rotation channels instead."""
    from motioncore.representation import decode_positions

    pos = decode_positions(feats, spec, start_yaw, dtype=torch.float64)  # no float64 copy of every feature
    pos[..., 0] += start_xz[0]
    pos[..., 2] += start_xz[1]
    pos = pos.float()  # the float64 copy is not kept while the fit runs
    return fit_positions(pos, fps, spec)


def limb_chains(sk: Skeleton) -> dict[str, list[int]]:
    """Each leaf joint below a branching joint (the hands and toes of the canonical skeleton) -> the joints
    whose rotations place it, from below the nearest branching ancestor down to its parent: e.g. Hand_L ->
    [Shoulder_L, UpperArm_L, LowerArm_L]. From the skeleton's topology, no joint names."""
    chains = {}
    for j in range(sk.num_joints):
        if sk.children(j) or sk.parents[j] < 0:
            continue
        chain, p = [], sk.parents[j]
        while p >= 0 and len(sk.children(p)) == 1:
            chain.insert(0, p)
            p = sk.parents[p]
        if chain and p >= 0:
            chains[sk.names[j]] = chain
    return chains


def decode_guarded(feats: torch.Tensor, fps: float, start_yaw: float = 0.0, start_xz: tuple[float, float] = (0.0, 0.0),
                   spec: CanonicalSpec = CANONICAL, reference: Motion | None = None, agree: float = 0.05,
                   disagree: float = 0.15) -> Motion:
    """Features ``(T, D)`` -> :class:`Motion` from the rotation channels, except where they disagree with the
    position channels about where a limb is. Per frame and limb (:func:`limb_chains`), the distance between the
    limb's end joint under the two decodings (hips-relative) blends the chain's global rotations from the
    rotation decode (under ``agree`` metres) to the position fit (:func:`decode_via_positions`, above
    ``disagree``) — when ``reference`` (the motion the features were made from, e.g. the content of a style
    transfer) is given, only where the position fit moves the limb less far from the reference's than the
    rotations do: of two readings that disagree, the smaller change. On motions whose two channel sets agree
    (real data) it is the rotation decode."""
    from motioncore.representation import decode

    by_rot = decode(feats, fps, spec, start_yaw, start_xz)
    by_pos = decode_via_positions(feats, fps, start_yaw, start_xz, spec)
    sk = spec.skeleton
    grot_r, gpos_r = fk(by_rot.lrot, by_rot.lpos, sk.parents)
    grot_p, gpos_p = fk(by_pos.lrot, by_pos.lpos, sk.parents)
    del by_pos  # a long take: what is no longer needed goes before the next whole-clip array is made
    rel_r, rel_p = gpos_r - gpos_r[:, :1], gpos_p - gpos_p[:, :1]
    del gpos_r, gpos_p
    rel_ref = None
    if reference is not None:
        if reference.num_frames != by_rot.num_frames:
            raise ValueError(f"decode_guarded: expected a reference of {by_rot.num_frames} frames, "
                             f"got {reference.num_frames}")
        g_ref = reference.global_positions()
        rel_ref = g_ref - g_ref[:, :1]
        del g_ref
    lrot = by_rot.lrot.clone()
    for end, chain in limb_chains(sk).items():
        e = sk.index(end)
        w = _smoothstep((rel_r[:, e] - rel_p[:, e]).norm(dim=-1), agree, disagree)  # (T,)
        if rel_ref is not None:  # the position fit only where it is the smaller change (2 cm soft margin)
            moved_r = (rel_r[:, e] - rel_ref[:, e]).norm(dim=-1)
            moved_p = (rel_p[:, e] - rel_ref[:, e]).norm(dim=-1)
            w = w * torch.sigmoid((moved_r - moved_p) / 0.02)
        if not bool((w > 1e-3).any()):
            continue
        parent_g = grot_r[:, sk.parents[chain[0]]]  # the branching joint, as the rotation decode has it
        for j in chain:  # blend in global space, so the parent's twist in either decoding does not turn the limb
            g = quat.slerp(grot_r[:, j], grot_p[:, j], w)
            lrot[:, j] = quat.mul(quat.inv(parent_g), g)
            parent_g = g
    return Motion(sk, quat.normalize(lrot), by_rot.lpos, fps)


# Joints whose bone roll is a convention of the training data, not a movement: the dataset's non-mirrored clips
# keep their mean local rotations within 26 deg of :data:`REFERENCE_LOCAL` (val, test; 54 deg at most in train,
# a Bandai-1 wave), videos within 30 deg, while rigs retargeted by the shortest arc (Xia, fair1) land 148-180 deg
# off: 90 deg about the Spine, Chest and Shoulders, 180 deg about UpperLeg_R (2026-12-05,
# docs/archive/RESULTS-notebook.md#foreign-rigs-bone-rolls-brought-into-the-datas-convention-issue-23-xia).
ROLL_CONVENTION_JOINTS = ("Spine", "Chest", "Shoulder_L", "Shoulder_R", "UpperLeg_L", "UpperLeg_R")
ROLL_CONVENTION_DEG = 90.0
# Leaves that keep their own turn when :func:`conform_rolls` solves a motion again (the head's nod, the wrists);
# the toes take the reference: in the data they barely turn, and many rigs have no toe bone.
CONFORM_KEPT_LEAVES = ("Head", "Hand_L", "Hand_R")


def roll_deviation(motion: Motion, spec: CanonicalSpec = CANONICAL) -> float:
    """Degrees: the largest angle, over :data:`ROLL_CONVENTION_JOINTS`, between a canonical motion's mean
    local rotation (:func:`reference_local_rotations`) and :data:`REFERENCE_LOCAL`'s."""
    if motion.skeleton.names != spec.skeleton.names:
        raise ValueError("roll_deviation: expected a motion on the canonical skeleton")
    idx = [spec.skeleton.index(n) for n in ROLL_CONVENTION_JOINTS]
    mean = reference_local_rotations([motion], spec.skeleton)[idx]
    ref = default_reference(spec.skeleton)[idx]
    return float(torch.rad2deg(quat.angle(quat.mul(quat.inv(ref), mean))).max())


def off_roll_convention(motion: Motion, spec: CanonicalSpec = CANONICAL) -> bool:
    """Whether a canonical motion's bone rolls lie off the training data's convention (:func:`roll_deviation` above
    :data:`ROLL_CONVENTION_DEG`): the one test of whether :func:`conform_rolls` solves it again."""
    return roll_deviation(motion, spec) > ROLL_CONVENTION_DEG


def conform_rolls(motion: Motion, spec: CanonicalSpec = CANONICAL, force: bool | None = None) -> Motion:
    """A canonical motion with its bones' rolls in the training data's convention, joint positions unchanged.

    A foreign rig retargeted by the shortest arc (:func:`motioncore.retarget.to_canonical`) puts the right
    joints in the right places, but each bone's roll about itself, which positions cannot show, is its own
    rig's: the rotation features then lie far outside anything the models were trained on. When the motion
    is off the convention (:func:`off_roll_convention`; ``force`` True/False decides instead, e.g. a decision made
    once for a whole take), its rotations are solved again from its joint positions as a video's are
    (:func:`fit_positions`: reference rolls, the data's knee and elbow hinges), and each leaf of
    :data:`CONFORM_KEPT_LEAVES` keeps its own turn relative to its parent, carried into the parent's new frame. A motion already in
    the convention (the dataset's, a video's, one written on the canonical skeleton) is returned as it is.
    """
    if not (off_roll_convention(motion, spec) if force is None else force):
        return motion
    sk = spec.skeleton
    grot, gpos = fk(motion.lrot, motion.lpos, sk.parents)
    fitted = fit_positions(gpos, motion.fps, spec)
    grot_fit, _ = fk(fitted.lrot, fitted.lpos, sk.parents)
    lrot = fitted.lrot.clone()
    for name in CONFORM_KEPT_LEAVES:
        j = sk.index(name)
        p = sk.parents[j]
        turn = quat.mul(quat.inv(grot[:, p]), grot_fit[:, p])  # the parent's new frame in its old one
        lrot[:, j] = quat.mul(quat.mul(quat.inv(turn), motion.lrot[:, j]), turn)
    return Motion(sk, quat.unroll(lrot, dim=0), fitted.lpos, motion.fps)
