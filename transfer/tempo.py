"""A style's tempo: how fast its example moves next to neutral clips of the same action (measured when it is
learned, :func:`style_tempo`), and the factor ``apply --tempo`` plays a clip at (:func:`resolve_tempo`)."""
from __future__ import annotations

from motioncore.motion import Motion, root_speed
from motioncore.representation import decode

LOCOMOTION = ("walk", "walk-turn-left", "walk-turn-right", "run")  # contents whose speed a style may change
TEMPO_RANGE = (0.5, 1.5)


def style_tempo(example: Motion, content_label: str, data, bundle) -> float | None:
    """How fast the canonical style ``example`` moves next to neutral clips of its content, ``content_label`` (median root speed of
    the content's "normal" clips in ``data``, normalised as ``bundle``'s models read them:
    :class:`transfer.bundle.MethodBundle`), clipped to :data:`TEMPO_RANGE`; None when the content is not
    locomotion or there are no such clips."""
    if content_label not in LOCOMOTION:
        return None
    idx = [i for i, r in enumerate(data.records) if r.style == "normal" and r.content == content_label][:50]
    speeds = sorted(root_speed(decode(bundle.denormalize(data.clip(i)))) for i in idx)
    if not speeds or speeds[len(speeds) // 2] <= 0.05:
        return None
    ratio = root_speed(example) / speeds[len(speeds) // 2]
    return float(min(max(ratio, TEMPO_RANGE[0]), TEMPO_RANGE[1]))


def resolve_tempo(style, tempo: str | float) -> float:
    """``--tempo``: "off" -> 1, "auto" -> the style's measured tempo (1 when it has none, :func:`style_tempo`), or a
    number; the factor a clip's playback speed is multiplied by before it is styled."""
    if tempo == "off":
        return 1.0
    if tempo == "auto":
        value = style.meta.get("tempo")
        return float(value) if isinstance(value, (int, float)) and TEMPO_RANGE[0] <= value <= TEMPO_RANGE[1] else 1.0
    try:
        value = float(tempo)
    except ValueError:
        value = float("nan")  # refused below, with the option's name
    if not TEMPO_RANGE[0] <= value <= TEMPO_RANGE[1]:
        raise ValueError(f"--tempo: expected off, auto or a number from {TEMPO_RANGE[0]} to {TEMPO_RANGE[1]}, got {tempo}")
    return value
