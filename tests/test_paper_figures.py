"""Every figure of the delivery study (16-20) and the replenishment study (9-12), redrawn from the
committed tables, is ready for a paper: one file per format, as wide as a journal column or page,
no text below 7 pt or outside the figure, and its panels lettered in the order its caption in
results/README.md letters them."""

import itertools
import re
import shutil
import string
from contextlib import contextmanager
from itertools import combinations
from pathlib import Path

import pytest

from dronefleet import figstyle, reproduce
from dronefleet.delivery import figures
from dronefleet.replenishment import figures as rfigures

matplotlib = pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parent.parent
STUDY_FIGURES = (*reproduce.DELIVERY_FIGURES, *reproduce.REPLENISHMENT_FIGURES)
#: Widths (in) a journal prints a figure at: one column, or the page's text width.
COLUMN_WIDTHS = {"single": (3.3, 3.6), "double": (6.8, 7.3)}


def caption(figure):
    """The **Caption.** paragraph of ``figure``'s section in results/README.md."""
    number = int(figure.removeprefix("fig"))
    text = (ROOT / "results" / "README.md").read_text()
    section = re.search(rf"^## Figure {number}:.*?(?=^## )", text, re.S | re.M).group(0)
    return " ".join(re.search(r"\*\*Caption\.\*\*(.*?)\n\n", section, re.S).group(1).split())


def caption_letters(figure):
    """The panel letters the caption names, ``["(a)", "(b)", ...]``: (a) and those that follow it
    (not "(x)" and "(y)", which name axes)."""
    named = set(re.findall(r"\(([a-z])\)", caption(figure)))
    return [f"({letter})" for letter in itertools.takewhile(named.__contains__, string.ascii_lowercase)]


@pytest.fixture(scope="module")
def study_figures(tmp_path_factory):
    """Every figure of both studies redrawn (``reproduce --redraw``) from a copy of the committed
    tables in this process (jobs=1: the figures are kept as drawn): {file name without suffix: (Figure, the files written)}."""
    root = tmp_path_factory.mktemp("redrawn")
    for figure in STUDY_FIGURES:
        (root / figure).mkdir()
        for table in (ROOT / "results" / figure).glob("*.parquet"):
            shutil.copy(table, root / figure)
    kept = {}
    with pytest.MonkeyPatch.context() as patch:
        for module in (figures, rfigures):
            @contextmanager
            def keeping(path, *args, original=module._figure, **kwargs):
                with original(path, *args, **kwargs) as (mpl, fig, axes):
                    kept[Path(path).stem] = fig
                    yield mpl, fig, axes

            patch.setattr(module, "_figure", keeping)
        drawn = reproduce.reproduce(list(STUDY_FIGURES), root, redraw=True, jobs=1, log=lambda *a, **k: None)
    return {name: (fig, drawn[name]) for name, fig in kept.items()}


def shown_texts(fig):
    """The texts that drawing ``fig`` draws (not, e.g., the labels of ticks beyond an axis's limits),
    in drawing order; the figure's layout done."""
    shown = []
    draw = matplotlib.text.Text.draw

    def recording(text, renderer):
        if text.get_visible() and text.get_text().strip():
            shown.append(text)
        return draw(text, renderer)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(matplotlib.text.Text, "draw", recording)
        fig.canvas.draw()
    return shown


def test_the_column_widths_are_a_journals():
    assert COLUMN_WIDTHS["single"][0] <= figstyle.SINGLE_COLUMN <= COLUMN_WIDTHS["single"][1]
    assert COLUMN_WIDTHS["double"][0] <= figstyle.DOUBLE_COLUMN <= COLUMN_WIDTHS["double"][1]
    assert figstyle.MIN_FONT_SIZE == 7.0


def test_each_figure_of_the_studies_is_one_drawing_in_each_format(study_figures):
    assert sorted(study_figures) == sorted(STUDY_FIGURES)
    for name, (_, files) in study_figures.items():
        drawings = [path for path in files if path.suffix in (".png", ".pdf", ".svg")]
        assert sorted(path.name for path in drawings) == [f"{name}.{suffix}" for suffix in ("pdf", "png", "svg")]


@pytest.mark.parametrize("figure", STUDY_FIGURES)
def test_a_figure_is_a_column_or_page_wide_and_no_text_is_below_7_pt_or_outside_it(study_figures, figure):
    fig, files = study_figures[figure]
    width = fig.get_size_inches()[0]
    assert width in (figstyle.SINGLE_COLUMN, figstyle.DOUBLE_COLUMN), width
    png = next(path for path in files if path.suffix == ".png")
    assert matplotlib.image.imread(png).shape[1] == round(width * figstyle.DPI)  # the file has that size too
    texts = shown_texts(fig)
    renderer = fig.canvas.get_renderer()
    frame = fig.bbox
    assert texts
    for text in texts:
        assert text.get_fontsize() >= figstyle.MIN_FONT_SIZE, (text.get_text(), text.get_fontsize())
        box = text.get_window_extent(renderer)
        assert frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1, text.get_text()  # not cut off
        assert frame.y0 - 1 <= box.y0 and box.y1 <= frame.y1 + 1, text.get_text()


@pytest.mark.parametrize("figure", STUDY_FIGURES)
def test_the_panels_are_lettered_in_the_order_the_caption_letters_them(study_figures, figure):
    fig, _ = study_figures[figure]
    texts = shown_texts(fig)
    renderer = fig.canvas.get_renderer()
    letters = [text for text in texts if re.fullmatch(r"\([a-z]\)", text.get_text())]
    # reading order: rows from the top, each from the left
    placed = sorted(letters, key=lambda text: (-round(text.get_window_extent(renderer).y0 / 20),
                                               text.get_window_extent(renderer).x0))
    assert [text.get_text() for text in placed] == caption_letters(figure)
    assert all(text.get_fontweight() == "bold" for text in placed)
    if figure in ("fig09", "fig10", "fig11", "fig12", "fig16", "fig19"):  # the captions of several panels
        assert len(placed) >= 2


@pytest.mark.parametrize("figure", ("fig16", "fig19"))
def test_the_tau_labels_of_panel_a_overlap_nothing_written(study_figures, figure):
    fig, _ = study_figures[figure]
    texts = shown_texts(fig)
    renderer = fig.canvas.get_renderer()
    panel = fig.axes[0]
    labels = [text for text in panel.texts if text.get_text().isdigit()]
    assert sorted({float(text.get_text()) for text in labels}) == [15.0, 20.0, 25.0, 30.0, 35.0, 40.0]
    others = [text for text in texts if text not in labels]
    for a, b in combinations(labels, 2):
        assert not a.get_window_extent(renderer).overlaps(b.get_window_extent(renderer)), (a.get_text(), b.get_text())
    for label in labels:
        box = label.get_window_extent(renderer)
        assert panel.bbox.contains(box.x0, box.y0) and panel.bbox.contains(box.x1, box.y1)
        assert not any(box.overlaps(other.get_window_extent(renderer)) for other in others), label.get_text()


def test_the_legend_of_figures_16_and_19_explains_the_marks(study_figures):
    for figure in ("fig16", "fig19"):
        fig, _ = study_figures[figure]
        entries = {text.get_text() for legend in fig.legends for text in legend.get_texts()}
        assert {"quartiles of 20 runs", "median, whiskers (1.5 IQR)", "runs beyond the whiskers"} <= entries
        assert any(entry.startswith("(a): tau (min)") for entry in entries)
        assert {"least_confident", "threshold(80)" if figure == "fig19" else "random"} <= entries


def test_figure_18_is_blue_to_red_and_its_caption_says_so(study_figures):
    fig, _ = study_figures["fig18"]
    (mesh, *_) = [artist for artist in fig.axes[0].collections if isinstance(artist, matplotlib.collections.QuadMesh)]
    low, high = mesh.get_cmap()(0.0), mesh.get_cmap()(1.0)
    assert low[2] > low[0] and high[0] > high[2]  # blue at the low end, red at the high end
    assert "blue" in caption("fig18") and "red" in caption("fig18") and "viridis" not in caption("fig18")


def test_the_captions_name_the_marks_the_replenishment_figures_draw(study_figures):
    fig, _ = study_figures["fig10"]
    means = {line.get_label(): line.get_marker() for line in fig.axes[0].lines
             if line.get_label().endswith("trials and mean")}
    assert means == {"fixed chargers: trials and mean": "s", "mobile chargers: trials and mean": "o"}
    text = caption("fig10")
    assert "blue squares" in text and "vermillion circles" in text
    for figure in ("fig09", "fig10", "fig11", "fig12"):
        assert "diamond" not in caption(figure)
