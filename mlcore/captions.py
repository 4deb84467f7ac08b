"""Content and style vocabularies of the Bandai-Namco datasets, and caption wording."""
from __future__ import annotations

CONTENT_PHRASES = {
    # Bandai-Namco-Research-Motiondataset-2
    "walk": "walks",
    "walk-turn-left": "walks and turns left",
    "walk-turn-right": "walks and turns right",
    "run": "runs",
    "wave-both-hands": "waves both hands",
    "wave-left-hand": "waves the left hand",
    "wave-right-hand": "waves the right hand",
    "raise-up-both-hands": "raises both hands",
    "raise-up-left-hand": "raises the left hand",
    "raise-up-right-hand": "raises the right hand",
    # Bandai-Namco-Research-Motiondataset-1 (seen styles)
    "dash": "dashes",
    "walk-back": "walks backwards",
    "walk-left": "walks sideways to the left",
    "walk-right": "walks sideways to the right",
    "bow": "bows",
    "bye": "waves goodbye",
    "byebye": "waves goodbye with both hands",
    "guide": "guides the way with a hand",
    "respond": "responds with a gesture",
    "call": "calls someone over",
    "punch": "punches",
    "kick": "kicks",
    "slash": "slashes with a sword",
    "dance-long": "dances",
    "dance-short": "dances",
}

# Dataset-1 spells some styles differently; one vocabulary for both.
STYLE_ALIASES = {"old": "elderly", "tired": "exhausted", "masculinity": "masculine"}
STYLES = ("active", "elderly", "exhausted", "feminine", "masculine", "normal", "youthful")
BANDAI2_CONTENTS = (
    "walk", "walk-turn-left", "walk-turn-right", "run", "wave-both-hands", "wave-left-hand",
    "wave-right-hand", "raise-up-both-hands", "raise-up-left-hand", "raise-up-right-hand",
)
NEUTRAL_STYLE = "normal"

MIRROR_CONTENT = {
    "walk-turn-left": "walk-turn-right", "wave-left-hand": "wave-right-hand",
    "raise-up-left-hand": "raise-up-right-hand", "walk-left": "walk-right",
}
MIRROR_CONTENT.update({v: k for k, v in list(MIRROR_CONTENT.items())})


def content_caption(content_label: str) -> str:
    """``"walk" -> "a person walks"``."""
    return f"a person {CONTENT_PHRASES.get(content_label, content_label.replace('-', ' '))}"


def caption(content_label: str, style_label: str | None) -> str:
    """``("walk", "elderly") -> "a person walks, elderly style"``; neutral style adds nothing."""
    base = content_caption(content_label)
    if not style_label or style_label == NEUTRAL_STYLE:
        return base
    return f"{base}, {style_label} style"
