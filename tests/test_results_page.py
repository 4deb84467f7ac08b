"""The results page in a real headless Chromium: the players draw the skeletons with no plug-in, no network."""
import shutil
import subprocess

import numpy as np
import pytest

from testkit.motions import random_motion
from video2style.results_page import page, player_html, write_player_data

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _page(tmp_path):
    key = str(tmp_path / "walk_player.js")
    m = random_motion(seconds=2.0, seed=1)
    write_player_data(tmp_path / "walk_player.js", key, [(m, "content"), (m, "style: test"), (m, "result")])
    html = page("t", [("v.mp4", "style test", [player_html(key, "walk_player.js", "walk.bvh", [("result", "walk.bvh")])])])
    (tmp_path / "index.html").write_text(html)
    return tmp_path / "index.html"


def test_player_data_is_a_script_a_file_url_can_load(tmp_path):
    _page(tmp_path)
    text = (tmp_path / "walk_player.js").read_text()
    assert text.startswith("window.V2S = window.V2S || {};") and '"panels"' in text and "style: test" in text


@pytest.mark.skipif(CHROMIUM is None, reason="no headless Chromium here (Debian: apt install chromium)")
def test_a_real_browser_draws_the_skeletons(tmp_path):
    import cv2

    index = _page(tmp_path)
    shot = tmp_path / "shot.png"
    subprocess.run([CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=900,500",
                    f"--screenshot={shot}", index.as_uri()], capture_output=True, timeout=120, check=True)
    img = cv2.imread(str(shot))
    b, g, r = (img[..., i].astype(int) for i in range(3))
    red = ((r > 150) & (g < 90) & (b < 90)).sum()  # the left limbs
    blue = ((b > 150) & (r < 80)).sum()  # the right limbs (links are blue too: count well above them)
    assert red > 200 and blue > 200, (red, blue)
    assert np.abs(img.astype(int) - [232, 235, 238]).sum(-1).min() < 10  # the canvas background is there


def test_the_page_says_what_apply_decided_on_its_own(tmp_path):
    """A clip whose style change the keeper scaled, or the still-pose guard smoothed, says so under its player,
    with the words apply prints; a clip where neither acted says nothing more than its name."""
    from video2style.batch import BatchReport, write_index
    from video2style.result import ApplyResult
    from video2style.summary import apply_notes

    assert apply_notes(ApplyResult("c.bvh", still_share=1.0, content_share=1.0, rolls_conformed=False)) == [] \
        == apply_notes(ApplyResult("c.bvh"))
    assert apply_notes(ApplyResult("c.bvh", rolls_conformed=True))[0].startswith("its rig rolls its bones its own way")
    notes = apply_notes(ApplyResult("c.bvh", still_share=0.0, content_share=0.5))
    assert notes[0].startswith("the style model barely moves on this clip, so 100% of its fast change")
    assert notes[1] == "style change scaled to 50% so the action still reads as the content's"
    arms = ("the example travels and this clip stays in place: its arms keep their own motion (4% of the style's), "
            "held where the example holds its arms")
    assert apply_notes(ApplyResult("c.bvh", arm_motion_share=0.04)) == [arms]
    out = tmp_path / "out"
    out.mkdir()
    report = BatchReport()
    for clip, row_notes in (("walk.bvh", notes), ("run.bvh", [])):
        (out / clip).write_text("x")
        report.add(video="v.mp4", clip=clip, status="done", style="style v", output=str(out / clip), notes=row_notes)
    text = write_index(report, out).read_text()
    assert "walk.bvh; the style model barely moves" in text and "reads as the content&#x27;s" in text
    assert "run.bvh;" not in text


NODE = shutil.which("node")

# a page's elements as far as the player script reaches them, and a clock run for a second (issue 51, item 7)
FAKE_DOM = r"""
const calls = []; let now = 0, queue = [];
const ctx = new Proxy({}, {get: (o, k) => k in o ? o[k] : () => calls.push(k), set: (o, k, v) => (o[k] = v, true)});
const canvas = {width: 720, height: 240, getContext: () => ctx, setPointerCapture() {}};
const slider = {value: 0, max: 0}, btn = {textContent: 'play'};
const el = {dataset: {key: 'k'}, querySelector: s => ({canvas, input: slider, button: btn})[s]};
globalThis.document = {querySelectorAll: () => [el]};
globalThis.window = globalThis;
window.matchMedia = q => ({matches: REDUCED && q.includes('reduced-motion')});
globalThis.requestAnimationFrame = f => queue.push(f);
globalThis.setTimeout = (f, ms) => queue.push(() => { now += ms; f(); });
window.V2S = {k: DATA};
PLAYER
for (let i = 0; i < 200 && queue.length && now < 1000; i++) queue.shift()(now);
console.log(JSON.stringify({button: btn.textContent, frame: +slider.value, drawn: calls.includes('stroke')}));
"""


@pytest.mark.skipif(NODE is None, reason="no node here to run the page's script")
@pytest.mark.parametrize("reduced", [False, True])
def test_the_page_plays_at_once_and_loops_unless_the_reader_asks_for_no_motion(tmp_path, reduced):
    import json

    from video2style.results_page import PLAYER_JS

    data = {"fps": 20, "frames": 10, "parents": [-1, 0], "left": [], "right": [1],
            "panels": [{"label": "content", "n": 10, "xyz": [0, 900, 0, 0, 1500, 0] * 10}]}
    script = tmp_path / "run.js"
    script.write_text(FAKE_DOM.replace("REDUCED", "true" if reduced else "false").replace("DATA", json.dumps(data))
                      .replace("PLAYER", PLAYER_JS))
    seen = json.loads(subprocess.run([NODE, str(script)], capture_output=True, text=True, check=True,
                                     timeout=60).stdout)
    assert seen["drawn"]  # the first frame is there at once
    if reduced:
        assert seen == {"button": "play", "frame": 0, "drawn": True}  # a still first frame and the play control
    else:
        assert seen["button"] == "pause" and seen["frame"] != 0  # playing, wrapped round the 10 frames (0.5 s)
