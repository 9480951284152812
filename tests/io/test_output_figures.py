"""Figures a reader can read: legends complete, tick labels clear, no empty bands, progress."""

from __future__ import annotations

from pathlib import Path

import pytest

EX = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture
def captured(monkeypatch):
    """The matplotlib figures handed to write_figure (still written)."""
    import grainmech.io.results as results

    figs = []
    orig = results.write_figure

    def keep(path, fig, dpi=120):
        figs.append(fig)
        return orig(path, fig, dpi)

    monkeypatch.setattr(results, "write_figure", keep)
    return figs


def test_fig6_9_legend_names_the_physical_convention_curves(tmp_path, captured):
    from grainmech.reproduce import build
    from grainmech.reproduce.plotting import plot

    d = build("6.9")
    plot(d, tmp_path / "f.png")
    ax = captured[-1].axes[0]
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    drawn = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-."]
    assert drawn and all(not ln.get_label().startswith("_") for ln in drawn)
    assert sum("physical convention" in t for t in texts) == len(drawn)


def test_fig4_2_radial_labels_few_and_on_a_background(tmp_path, captured):
    from grainmech.reproduce import build
    from grainmech.reproduce.plotting import plot

    plot(build("4.2"), tmp_path / "f.png")
    for ax in captured[-1].axes:
        labels = [lab for lab in ax.get_yticklabels() if lab.get_text()]
        assert 1 <= len(labels) <= 4
        assert all(lab.get_bbox_patch() is not None for lab in labels)


def test_calibrate_plot_has_no_empty_band_under_the_title(tmp_path, captured):
    from grainmech.calibrate import fit, load_problem
    from grainmech.calibrate.report import plot_fit

    problem = load_problem(EX / "calibrate_hardin_black.toml", EX / "calibrate_hardin_black.csv")
    plot_fit(fit(problem), tmp_path / "fit.png")
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = captured[-1]
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    title_bottom = fig._suptitle.get_window_extent(renderer).y0
    ax_top = max(ax.get_tightbbox(renderer).y1 for ax in fig.axes)
    assert 0 <= title_bottom - ax_top < 0.05 * fig.bbox.height  # a gap of a few pixels, no band


def test_long_figure_reports_progress_inside():
    from grainmech.reproduce import stress_paths
    from grainmech.reproduce._base import reporting

    lines: list[str] = []
    with reporting(lines.append):
        stress_paths.compute((1.0, 1.5), 2, 7)
    assert len(lines) == 2 * len(stress_paths.PATHS)
    assert lines[0].startswith("  path compression (1/3): state estimate")
