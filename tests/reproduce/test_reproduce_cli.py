"""`grainmech reproduce`: files written, index.html contents, user errors (exit 2)."""

import csv
import html

from grainmech.reproduce import build, reproduce


def test_cli_one_figure_writes_png_csv_and_index(tmp_path, cli):
    out = tmp_path / "out"
    res = cli("reproduce", "fig4.3", "-o", str(out))
    assert res.rc == 0
    assert "fig4_3.png" in res.out
    png = out / "fig4_3.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "fig4_3.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["ks_kn", "E", "nu", "G"]
    assert float(rows[1][2]) == 0.25
    index = (out / "index.html").read_text()
    assert "fig4_3.png" in index and "data:image/png;base64," in index
    assert html.escape(build("4.3").caption) in index
    assert "src='http" not in index and 'src="http' not in index  # no external assets


def test_index_has_every_requested_figure(tmp_path):
    figs = reproduce(["4.2", "6.8", "6.7"], tmp_path, log=None)
    assert [f.fig_id for f in figs] == ["4.2", "6.7", "6.8"]
    index = (tmp_path / "index.html").read_text()
    for f in figs:
        assert (tmp_path / f"{f.stem}.png").exists() and (tmp_path / f"{f.stem}.csv").exists()
        assert f"alt='{f.stem}.png'" in index
        assert html.escape(f.caption) in index
    assert "fig4_3" not in index
    assert "<script" not in index and "<link" not in index


def test_unknown_figure_exit_2(tmp_path, cli):
    res = cli("reproduce", "4.1", "-o", str(tmp_path))
    assert res.rc == 2
    err = res.err.strip()
    assert err.startswith("grainmech: error: unknown figure '4.1'") and "\n" not in err


def test_unwritable_outdir_exit_2(tmp_path, cli):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    res = cli("reproduce", "4.3", "-o", str(blocker / "sub"))
    assert res.rc == 2
    err = res.err.strip()
    assert err.startswith("grainmech: error:") and "\n" not in err
