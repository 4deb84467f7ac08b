"""What applying a style (or Park et al.'s stylizer) to one clip gave: :class:`ApplyResult`, read by the summary
line, ``report.json`` (:func:`video2style.summary.clip_details`) and the results page."""
from __future__ import annotations

from dataclasses import dataclass, field, fields


def _reported() -> dict:
    return {"reported": True}


@dataclass
class ApplyResult:
    """One clip's result. A field left None was not measured for this clip (the method did not decide it, or the
    path it took does not make it) and is left out of the clip's row of ``report.json`` (:meth:`reported`); the
    reported fields, in this order, are the row's.

    Files: ``input`` (the clip read), ``outputs`` (the result files written: one, or one per variant), ``preview``
    (the mp4) and ``player`` (the results page's data), None under ``--no-preview``.
    Length: ``frames`` (canonical frames styled), ``file_frames`` and ``file_fps`` (the written file's own),
    ``tempo`` (how many times as fast the content was played).
    The method's decisions (:func:`transfer.spans.stylize_spans`): ``detected`` (the motion encoder's reading of
    the content; None when not read) and ``neutralized`` (styled content neutralised first); the foot-skating
    ratios ``skating_content`` (the content's), ``skating_before`` and ``skating_after`` (the result's, before and
    after foot cleanup), ``skating_low_steps`` (the share of the result's frames where a foot is low and fast while
    the content's is in swing: low steps, not slides), ``feet_cleaned`` (``--feet``: the feet were cleaned; None where none was asked for, ``--feet off`` or
    ``--strength 0``; a long
    take: in every span, ``feet_cleaned_spans`` in how many, not reported), ``swing_example`` and ``swing_result``
    (the toes' swing clearance, metres, :func:`motioncore.feet.swing_clearance`); the guards' shares, 1 where a
    guard held nothing back: ``still_share`` (the fast change the still-pose guard kept), ``arm_motion_share`` (the
    style's share of the arms' motion on a clip done in place), ``content_share`` (the style's change the content
    keeper kept).
    ``rolls_conformed``: the clip's rig rolls its bones its own way and its rotations were solved again;
    ``change``: how far the joints moved from the content (:func:`video2style.summary.motion_change`).
    Time: ``seconds`` (in all), ``seconds_transfer`` (reading and styling). Notes for the user: ``preview_note``
    (the preview shows only the first part), ``stream_note`` (how a long take was applied); ``streamed``: the
    spans a long take was applied in (not reported)."""

    input: str = field(metadata=_reported())
    outputs: list[str] = field(default_factory=list, metadata=_reported())
    preview: str | None = field(default=None, metadata=_reported())
    player: str | None = field(default=None, metadata=_reported())
    frames: int | None = field(default=None, metadata=_reported())
    file_frames: int | None = field(default=None, metadata=_reported())
    file_fps: float | None = field(default=None, metadata=_reported())
    tempo: float | None = field(default=None, metadata=_reported())
    detected: str | None = field(default=None, metadata=_reported())
    neutralized: bool | None = field(default=None, metadata=_reported())
    skating_content: float | None = field(default=None, metadata=_reported())
    skating_before: float | None = field(default=None, metadata=_reported())
    skating_after: float | None = field(default=None, metadata=_reported())
    skating_low_steps: float | None = field(default=None, metadata=_reported())
    feet_cleaned: bool | None = field(default=None, metadata=_reported())
    swing_example: float | None = field(default=None, metadata=_reported())
    swing_result: float | None = field(default=None, metadata=_reported())
    still_share: float | None = field(default=None, metadata=_reported())
    arm_motion_share: float | None = field(default=None, metadata=_reported())
    content_share: float | None = field(default=None, metadata=_reported())
    rolls_conformed: bool | None = field(default=None, metadata=_reported())
    change: dict | None = field(default=None, metadata=_reported())
    seconds: float | None = field(default=None, metadata=_reported())
    seconds_transfer: float | None = field(default=None, metadata=_reported())
    preview_note: str | None = field(default=None, metadata=_reported())
    stream_note: str | None = field(default=None, metadata=_reported())
    streamed: int | None = None
    feet_cleaned_spans: int | None = None

    @property
    def output(self) -> str:
        """The first (for one result, the only) result file."""
        return self.outputs[0]

    def add_files(self, paths: dict) -> None:
        """Take the paths a writer returned (:func:`video2style.pipeline.write_outputs`: ``outputs``, and
        ``preview``, ``player``, ``preview_note`` where it made them)."""
        for key in ("outputs", "preview", "player", "preview_note"):
            if key in paths:
                setattr(self, key, paths[key])

    def reported(self) -> dict:
        """The reported fields that were measured, in order (``report.json``'s row; ``outputs`` as ``output``: the
        only file, or the list of them). ``detected`` goes with ``neutralized``: None there means the content was
        not read."""
        row = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if not f.metadata.get("reported"):
                continue
            if f.name == "outputs":
                row["output"] = value[0] if len(value) == 1 else list(value)
            elif value is not None or (f.name == "detected" and self.neutralized is not None):
                row[f.name] = value
        return row
