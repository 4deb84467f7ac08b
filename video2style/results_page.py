"""The results page: every clip as an in-page player that draws the skeletons itself.

Browsers do not play the mp4v previews OpenCV writes, and no H.264 encoder ships in a wheel we may
depend on, so the page carries the joint positions instead: for each result a small script
(``<clip>_player.js``, next to its BVH) with the content, the style example and the result as
millimetre integers at the canonical frame rate, and one player script in the page that draws
them side by side on a canvas — a still frame at once (the poster), then it plays, looping (not where
the reader's system asks for reduced motion: there the first frame waits for play), with pause,
scrubbing and orbiting (drag). Works from a folder opened as ``file://``, with no network.
"""
from __future__ import annotations

import html
import json
from pathlib import Path

from motioncore.files import atomic_write_text
from motioncore.motion import Motion

MAX_SECONDS = 120.0  # as the mp4 preview


def write_player_data(path: Path, key: str, panels: list[tuple[Motion, str]]) -> Path:
    """``panels``: ``[(canonical motion, label)]`` drawn side by side; writes ``path`` (a .js file)."""
    first = panels[0][0]
    frames = min(max(m.num_frames for m, _ in panels), int(MAX_SECONDS * first.fps))
    data = {"fps": first.fps, "frames": frames, "parents": list(first.skeleton.parents),
            "left": [i for i, n in enumerate(first.skeleton.names) if n.endswith("_L")],
            "right": [i for i, n in enumerate(first.skeleton.names) if n.endswith("_R")], "panels": []}
    for motion, label in panels:
        pos = motion.global_positions()[:frames]
        pos = pos - pos.new_tensor([float(pos[0, 0, 0]), 0.0, float(pos[0, 0, 2])])  # start at the origin
        data["panels"].append({"label": label, "n": pos.shape[0],
                               "xyz": [round(v) for v in (pos * 1000).flatten().tolist()]})
    text = f"window.V2S = window.V2S || {{}};\nwindow.V2S[{json.dumps(key)}] = {json.dumps(data, separators=(',', ':'))};\n"
    atomic_write_text(Path(path), text)
    return Path(path)


PLAYER_JS = r"""
function v2sPlayer(el, d) {
  const cv = el.querySelector('canvas'), ctx = cv.getContext('2d'), slider = el.querySelector('input');
  const btn = el.querySelector('button'); let t = 0, playing = false, yaw = -0.6, pitch = 0.35, last = null;
  slider.max = d.frames - 1;
  const side = j => d.left.includes(j) ? '#d72828' : d.right.includes(j) ? '#1478c8' : '#333';
  function draw() {
    const w = cv.width / d.panels.length, h = cv.height;
    ctx.fillStyle = '#eeebe8'; ctx.fillRect(0, 0, cv.width, cv.height);
    d.panels.forEach((p, k) => {
      const f = Math.min(t, p.n - 1), J = d.parents.length, o = f * J * 3;
      const cx = p.xyz[o] / 1000, cz = p.xyz[o + 2] / 1000;
      const proj = (x, y, z) => {  // orbit about the figure, then a simple perspective
        x -= cx; z -= cz; y -= 0.9;
        const xr = x * Math.cos(yaw) - z * Math.sin(yaw), zr = x * Math.sin(yaw) + z * Math.cos(yaw);
        const yr = y * Math.cos(pitch) - zr * Math.sin(pitch), zz = y * Math.sin(pitch) + zr * Math.cos(pitch) + 3.2;
        return [k * w + w / 2 + xr * h * 1.45 / zz, h * 0.5 - yr * h * 1.45 / zz];
      };
      ctx.strokeStyle = '#ccc'; ctx.lineWidth = 1;  // the floor
      for (let g = -1.5; g <= 1.5; g += 0.5) {
        let a = proj(cx + g, 0, cz - 1.5), b = proj(cx + g, 0, cz + 1.5); ctx.beginPath(); ctx.moveTo(...a); ctx.lineTo(...b); ctx.stroke();
        a = proj(cx - 1.5, 0, cz + g); b = proj(cx + 1.5, 0, cz + g); ctx.beginPath(); ctx.moveTo(...a); ctx.lineTo(...b); ctx.stroke();
      }
      ctx.lineWidth = Math.max(2, h / 90); ctx.lineCap = 'round';
      for (let j = 1; j < J; j++) {
        const a = proj(p.xyz[o + 3 * j] / 1000, p.xyz[o + 3 * j + 1] / 1000, p.xyz[o + 3 * j + 2] / 1000);
        const q = d.parents[j], b = proj(p.xyz[o + 3 * q] / 1000, p.xyz[o + 3 * q + 1] / 1000, p.xyz[o + 3 * q + 2] / 1000);
        ctx.strokeStyle = side(j); ctx.beginPath(); ctx.moveTo(...a); ctx.lineTo(...b); ctx.stroke();
      }
      ctx.fillStyle = '#222'; ctx.font = (h / 22) + 'px sans-serif'; ctx.fillText(p.label, k * w + 8, h / 14);
      if (k > 0) { ctx.fillStyle = '#999'; ctx.fillRect(k * w, 0, 1, h); }
    });
    ctx.fillStyle = '#666'; ctx.fillText((t / d.fps).toFixed(2) + ' s', 8, h - 8);
    slider.value = t;
  }
  function tick(now) {
    if (!playing) return;
    if (last !== null) t = (t + Math.max(1, Math.round((now - last) * d.fps / 1000))) % d.frames;
    last = now; draw(); setTimeout(() => requestAnimationFrame(tick), 1000 / d.fps);
  }
  btn.onclick = () => { playing = !playing; btn.textContent = playing ? 'pause' : 'play'; last = null; if (playing) requestAnimationFrame(tick); };
  slider.oninput = () => { t = +slider.value; draw(); };
  let drag = null;
  cv.onpointerdown = e => { drag = [e.clientX, e.clientY]; cv.setPointerCapture(e.pointerId); };
  cv.onpointermove = e => { if (!drag) return; yaw += (e.clientX - drag[0]) / 150; pitch = Math.max(-0.2, Math.min(1.2, pitch + (e.clientY - drag[1]) / 150)); drag = [e.clientX, e.clientY]; draw(); };
  cv.onpointerup = () => { drag = null; };
  draw();  // the first frame at once, with the play control beside it
  const still = window.matchMedia && window.matchMedia('(prefers-reduced-motion: reduce)').matches;
  if (!still) btn.onclick();  // then it plays, looping (a drawing: no sound), unless the reader asked for no motion
}
document.querySelectorAll('.player').forEach(el => { const d = (window.V2S || {})[el.dataset.key]; if (d) v2sPlayer(el, d); });
"""


def player_html(key: str, script_rel: str, caption: str, links: list[tuple[str, str]]) -> str:
    """One clip's player: a canvas (drawn at once: the poster), play/pause, a time slider, links."""
    link_html = " · ".join(f'<a href="{html.escape(href)}">{html.escape(text)}</a>' for text, href in links)
    return (f'<figure class="player" data-key="{html.escape(key)}"><canvas width="720" height="240"></canvas>'
            f'<div><button>play</button> <input type="range" min="0" value="0" step="1"></div>'
            f"<figcaption>{html.escape(caption)}<br>{link_html}</figcaption></figure>"
            f'<script src="{html.escape(script_rel)}"></script>')


def page(title: str, sections: list[tuple[str, str, list[str]]], note: str = "") -> str:
    """The whole page: ``sections`` of ``(heading, description, [figure html])``."""
    body = "".join(f"<h2>{html.escape(h)}</h2><p>{html.escape(desc)}</p><div class=row>{''.join(figs)}</div>"
                   for h, desc, figs in sections)
    return ("<!doctype html><meta charset=utf-8>"
            f"<title>{html.escape(title)}</title>"
            "<style>body{font-family:sans-serif;margin:16px}.row{display:flex;flex-wrap:wrap;gap:12px}"
            "figure{margin:0}canvas{border:1px solid #bbb;cursor:grab;max-width:100%}figcaption{font-size:90%}"
            "input[type=range]{width:560px}</style>"
            f"<h1>{html.escape(title)}</h1><p>{html.escape(note)}</p>{body}"
            f"<script>{PLAYER_JS}</script>")
