"""The output page opens in a real browser (issue 5: "index.html opens in a browser ...
showing plots and numbers"): headless Chromium renders index.html of a small `grainmech run`
via scripts/screenshot_index.sh; the screenshot must show a page with content (plots are
embedded as data: URIs, so a broken image would leave large blank areas).

Skipped where Chromium is not installed (Debian: apt-get install chromium).
"""

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from grainmech.cli import main

ROOT = Path(__file__).resolve().parents[1]
BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")

CFG = """
[packing]
void_ratio = 0.65
coordination = 6.75
radius = "0.25 mm"
[contacts]
law = "mindlin-deresiewicz"
shear_modulus = "44 GPa"
poisson = 0.08
friction = 0.5
[initial]
pressure = "100 kPa"
[test]
kind = "cyclic-simple-shear"
amplitudes = [1e-5, 1e-4, 1e-3]
n_cycles = 2
steps_per_cycle = 16
[quadrature]
degree = 9
"""


@pytest.mark.skipif(BROWSER is None, reason="chromium not installed")
def test_index_html_renders_in_headless_chromium(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(CFG)
    out = tmp_path / "out"
    assert main(["run", str(cfg), "-o", str(out), "--quiet"]) == 0
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
