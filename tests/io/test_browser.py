"""The output page opens in a real browser and shows plots and numbers: headless Chromium
renders index.html of a small `grainmech run` via scripts/screenshot_index.sh; the
screenshot must show a page with content (plots are embedded as data: URIs, so a broken
image would leave large blank areas).

Skipped where Chromium is not installed (Debian: apt-get install chromium).
"""

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import CYCLIC as CFG  # the small cyclic run of the CLI tests

ROOT = Path(__file__).resolve().parents[2]
BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(BROWSER is None, reason="chromium not installed")
def test_index_html_renders_in_headless_chromium(tmp_path, cli):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CFG)
    out = tmp_path / "out"
    assert cli("run", str(cfg), "-o", str(out), "--quiet").rc == 0
    png = tmp_path / "shot.png"
    r = subprocess.run(["bash", str(ROOT / "scripts" / "screenshot_index.sh"), str(out), str(png)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    import matplotlib.image as mpimg

    img = mpimg.imread(png)
    assert img.shape[0] >= 1000 and img.shape[1] >= 1000
    gray = img[..., :3].mean(axis=2)
    # a rendered page: mostly white background, but with text and plot lines (dark pixels)
    # spread over the page height, i.e. the embedded plots were drawn
    dark = gray < 0.5
    assert dark.mean() > 0.005
    rows_with_ink = np.nonzero(dark.any(axis=1))[0]
    assert rows_with_ink.max() - rows_with_ink.min() > 0.5 * img.shape[0]
