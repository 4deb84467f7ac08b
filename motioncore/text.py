"""Text from outside (a child process, a file's names) made safe to print: printable characters only."""
from __future__ import annotations


def printable(text: object, limit: int | None = None) -> str:
    """``text`` with every character that is not printable (ESC and other controls, newlines) replaced by a space,
    runs of spaces made one, cut to ``limit`` characters ("..." at the end) when given: a crafted name cannot clear
    or recolour the user's terminal, nor make a one-line message several."""
    s = "".join(ch if ch.isprintable() else " " for ch in str(text))
    s = " ".join(s.split())
    if limit is not None and len(s) > limit:
        s = s[: max(0, limit - 3)] + "..."
    return s
