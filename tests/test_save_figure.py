"""``save_figure``: the reports' PNG and SVG files, cropped as matplotlib's "tight" crops them."""

import io
import re

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from replication.report.figures import DPI, save_figure


def _figure() -> Figure:
    """Two panels with a colorbar, a suptitle and a label that sticks out of the axes: a
    layout ``tight_layout`` moves and a crop that clips something if it is too small."""
    fig = Figure(figsize=(6, 3))
    axes = fig.subplots(1, 2)
    x = np.linspace(0, 1, 30)
    image = axes[0].imshow(np.outer(x, x), extent=(0, 1, 0, 1))
    fig.colorbar(image, ax=axes[0], label="a colorbar's label")
    axes[1].plot(x, x**2)
    axes[1].set_ylabel("a long label, drawn outside the axes", fontsize=12)
    fig.suptitle("a suptitle")
    fig.tight_layout()
    return fig


def _matplotlib_tight(fig: Figure, ext: str) -> bytes:
    """The figure saved by matplotlib's own ``bbox_inches="tight"``, as save_figure's options."""
    FigureCanvasAgg(fig)
    buffer = io.BytesIO()
    metadata = {"Date": None} if ext == "svg" else {"Software": None}
    fig.savefig(buffer, format=ext, dpi=DPI, metadata=metadata, bbox_inches="tight")
    return buffer.getvalue()


def _svg_size(svg: bytes) -> tuple[float, float]:
    found = re.search(rb'<svg[^>]* width="([0-9.]+)pt" height="([0-9.]+)pt"', svg)
    assert found, svg[:300]
    return float(found[1]), float(found[2])


def test_the_png_is_matplotlib_s_tight_png_byte_for_byte(tmp_path):
    """One layout pass for both formats, at the PNG's dpi: the PNG is exactly the file
    matplotlib's "tight" writes."""
    (png,) = save_figure(_figure(), tmp_path / "f", formats=("png",))
    assert png == tmp_path / "f.png"
    assert png.read_bytes() == _matplotlib_tight(_figure(), "png")


def test_the_svg_has_matplotlib_s_tight_size_within_a_point(tmp_path):
    """The SVG is cropped by the box found at 150 dpi, not at the SVG's 72: text measured at
    another size differs by a fraction of a point, nothing more."""
    save_figure(_figure(), tmp_path / "f")
    ours = _svg_size((tmp_path / "f.svg").read_bytes())
    theirs = _svg_size(_matplotlib_tight(_figure(), "svg"))
    assert ours == pytest.approx(theirs, abs=1.0)
    assert ours != pytest.approx((6 * 72, 3 * 72), abs=5.0)  # cropped, not the whole figure


def test_the_figure_is_laid_out_once_and_drawn_once_per_format(tmp_path, monkeypatch):
    """Matplotlib's "tight" lays the figure out again before each format's draw (a draw with
    drawing turned off): 4 draws for two formats where 3 do (one layout pass, one draw per
    format)."""
    drawn = []
    original = Figure.draw
    monkeypatch.setattr(Figure, "draw", lambda self, renderer: drawn.append(1) or original(self, renderer))
    fig = _figure()
    save_figure(fig, tmp_path / "f")
    assert len(drawn) == 3
    assert fig.get_layout_engine() is None  # the layout saved is the one it keeps


def test_a_matplotlibrc_layout_engine_does_not_move_the_saved_layout(tmp_path):
    """``figure.autolayout`` in the user's matplotlibrc would give the figure a tight-layout
    engine again, which would lay it out anew at each format's draw."""
    import matplotlib

    save_figure(_figure(), tmp_path / "plain")
    with matplotlib.rc_context({"figure.autolayout": True}):
        fig = _figure()
        save_figure(fig, tmp_path / "rc")
    assert fig.get_layout_engine() is None
    for ext in ("png", "svg"):
        assert (tmp_path / f"rc.{ext}").read_bytes() == (tmp_path / f"plain.{ext}").read_bytes()


def test_the_same_figure_gives_the_same_bytes(tmp_path):
    save_figure(_figure(), tmp_path / "a")
    save_figure(_figure(), tmp_path / "b")
    for ext in ("png", "svg"):
        assert (tmp_path / f"a.{ext}").read_bytes() == (tmp_path / f"b.{ext}").read_bytes()


def _renderers_made(monkeypatch) -> list[float]:
    from matplotlib.backends import backend_agg

    made = []
    original = backend_agg.RendererAgg.__init__

    def init(self, width, height, dpi):
        made.append(dpi)
        original(self, width, height, dpi)

    monkeypatch.setattr(backend_agg.RendererAgg, "__init__", init)
    return made


def _laid_out(fig: Figure) -> Figure:
    axes = fig.subplots(1, 2)
    axes[0].plot([0, 1], [0, 1])
    axes[1].set_ylabel("a label")
    fig.suptitle("a suptitle")
    fig.tight_layout()
    return fig


def test_a_new_figure_is_laid_out_and_saved_with_one_renderer(tmp_path, monkeypatch):
    """Matplotlib caches text extents per renderer: a figure made at the saved dpi on its Agg
    canvas measures its text for ``tight_layout``, the layout pass and the bounding box with
    one renderer (the cropped PNG, of another size, draws on a second). A plain ``Figure`` is
    laid out at 100 dpi on a renderer of its own."""
    from replication.report.figures import new_figure

    made = _renderers_made(monkeypatch)
    fig = new_figure((6, 3))
    assert fig.dpi == DPI and isinstance(fig.canvas, FigureCanvasAgg)
    save_figure(_laid_out(fig), tmp_path / "new", formats=("png",))
    assert made == [DPI, DPI], made  # one for the layout, its pass and the box; one for the cropped PNG

    made.clear()
    save_figure(_laid_out(Figure(figsize=(6, 3))), tmp_path / "plain", formats=("png",))
    assert made == [100, DPI, DPI], made
