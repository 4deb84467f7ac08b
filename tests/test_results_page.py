"""The results page in a real headless Chromium: the players draw the skeletons with no plug-in, no network."""
import shutil
import subprocess

import numpy as np
import pytest

from tests.helpers import random_motion
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
