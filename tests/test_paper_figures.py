"""Every figure of the delivery study (16-20), the replenishment study (9-12) and the items study
(items-fig01..12, each option variant), redrawn from the committed tables, is ready for a paper:
one file per format, as wide as a journal column or page, no text below 7 pt or outside the
figure, and its panels lettered in the order its caption in results/README.md letters them."""

import itertools
import re
import shutil
import string
from contextlib import contextmanager
from itertools import combinations
from pathlib import Path

import numpy as np
import pytest

from dronefleet import figstyle, reproduce
from dronefleet.delivery import figures
from dronefleet.items import experiments as iexperiments
from dronefleet.items import figures as ifigures
from dronefleet.items import study as istudy
from dronefleet.replenishment import figures as rfigures

matplotlib = pytest.importorskip("matplotlib")
mplot3d = pytest.importorskip("mpl_toolkits.mplot3d")

ROOT = Path(__file__).resolve().parent.parent
STUDY_FIGURES = (*reproduce.DELIVERY_FIGURES, *reproduce.REPLENISHMENT_FIGURES)
#: Widths (in) a journal prints a figure at: one column, or the page's text width.
COLUMN_WIDTHS = {"single": (3.3, 3.6), "double": (6.8, 7.3)}


ITEMS_FIGURES = tuple(figure for figure in istudy.FIGURES if figure not in ("items-ttests", "items-verdicts"))  # tables


def caption(figure):
    """The **Caption.** paragraph of ``figure``'s section in results/README.md (an items figure:
    its "#### Fig N:" section under "Items: figures")."""
    text = (ROOT / "results" / "README.md").read_text()
    if figure.startswith("items-"):
        items = re.search(r"^### Items: figures$.*?(?=^## )", text, re.S | re.M).group(0)
        section = re.search(rf"^#### Fig {int(figure[-2:])}:.*?(?=^####? |\Z)", items, re.S | re.M).group(0)
    else:
        section = re.search(rf"^## Figure {int(figure.removeprefix('fig'))}:.*?(?=^## )", text, re.S | re.M).group(0)
    return " ".join(re.search(r"\*\*Caption\.\*\*(.*?)\n\n", section, re.S).group(1).split())


def caption_letters(figure):
    """The panel letters the caption names, ``["(a)", "(b)", ...]``: (a) and those that follow it
    (not "(x)" and "(y)", which name axes)."""
    named = set(re.findall(r"\(([a-z])\)", caption(figure)))
    return [f"({letter})" for letter in itertools.takewhile(named.__contains__, string.ascii_lowercase)]


def redrawn(root, names, modules):
    """The figures ``names`` redrawn (``reproduce --redraw``) in this process (jobs=1: the figures
    are kept as drawn) from a copy of their committed tables under ``root``, each drawing of
    ``modules`` kept: ({file name without suffix: Figure}, {figure: the files written})."""
    for figure in names:
        (root / figure).mkdir()
        for table in (ROOT / "results" / figure).glob("*.parquet"):
            shutil.copy(table, root / figure)
    kept = {}
    with pytest.MonkeyPatch.context() as patch:
        for module in modules:
            @contextmanager
            def keeping(path, *args, original=module._figure, **kwargs):
                with original(path, *args, **kwargs) as (mpl, fig, axes):
                    kept[Path(path).stem] = fig
                    yield mpl, fig, axes

            patch.setattr(module, "_figure", keeping)
        drawn = reproduce.reproduce(list(names), root, redraw=True, jobs=1, log=lambda *a, **k: None)
    return kept, drawn


@pytest.fixture(scope="module")
def study_figures(tmp_path_factory):
    """Every figure of the delivery and replenishment studies redrawn from the committed tables:
    {file name without suffix: (Figure, the files written)}."""
    kept, drawn = redrawn(tmp_path_factory.mktemp("redrawn"), STUDY_FIGURES, (figures, rfigures))
    return {name: (fig, drawn[name]) for name, fig in kept.items()}


@pytest.fixture(scope="module")
def items_figures(tmp_path_factory):
    """Every items figure redrawn from the committed tables: {file name without suffix (the
    figure, or the figure and its option tag): (Figure, its files)}."""
    root = tmp_path_factory.mktemp("items")
    kept, _ = redrawn(root, ITEMS_FIGURES, (ifigures,))
    return {name: (fig, sorted((root / name[:len("items-figNN")]).glob(f"{name}.*"))) for name, fig in kept.items()}


def items_names(figure):
    """The drawings of the items figure ``figure`` committed in results/ (its variants too)."""
    return sorted(path.stem for path in (ROOT / "results" / figure).glob("*.png"))


ITEMS_DRAWINGS = [name for figure in ITEMS_FIGURES for name in items_names(figure)]


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


def test_each_items_figure_is_one_file_per_option_and_every_drawing_is_committed(items_figures):
    assert sorted(items_figures) == sorted(ITEMS_DRAWINGS)
    for figure in ITEMS_FIGURES:
        names = items_names(figure)
        assert figure in names  # the defaults' drawing is named as the figure
        assert len(names) <= 4, names  # option variants: one file each, not one per panel or kind
    for name, (_, files) in items_figures.items():
        assert [path.name for path in files] == [f"{name}.{suffix}" for suffix in ("pdf", "png", "svg")]


def _pdf_width_in(path):
    """The width (in) of a one-page PDF's MediaBox."""
    box = re.search(rb"/MediaBox\s*\[\s*([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s*\]", path.read_bytes())
    return (float(box.group(3)) - float(box.group(1))) / 72.0


@pytest.mark.parametrize("name", ITEMS_DRAWINGS)
def test_an_items_figure_is_a_column_or_page_wide_and_no_text_is_below_7_pt_outside_it_or_on_another(
        items_figures, name):
    fig, files = items_figures[name]
    width = fig.get_size_inches()[0]
    assert width in (figstyle.SINGLE_COLUMN, figstyle.DOUBLE_COLUMN), width
    committed = ROOT / "results" / name[:len("items-figNN")] / name
    assert abs(_pdf_width_in(committed.with_suffix(".pdf")) - width) < 0.01
    assert matplotlib.image.imread(committed.with_suffix(".png")).shape[1] == round(width * figstyle.DPI)
    texts = shown_texts(fig)
    renderer = fig.canvas.get_renderer()
    frame = fig.bbox
    for text in texts:
        assert text.get_fontsize() >= figstyle.MIN_FONT_SIZE, (text.get_text(), text.get_fontsize())
        box = text.get_window_extent(renderer)
        assert frame.x0 - 1 <= box.x0 and box.x1 <= frame.x1 + 1, text.get_text()
        assert frame.y0 - 1 <= box.y0 and box.y1 <= frame.y1 + 1, text.get_text()
    outlines = [(text.get_text(), _outline(text, renderer)) for text in texts]
    for (a, outline_a), (b, outline_b) in combinations(outlines, 2):
        assert not outline_a.intersects_path(outline_b, filled=True), (a, b)


def _outline(text, renderer):
    """The rectangle ``text`` covers on the canvas (px), turned with it (a 3-D axis's label is
    turned along its axis: its upright bounding box would cover the tick labels beside it),
    shrunk by half a pixel: texts that only touch do not overlap."""
    box = text.get_window_extent(renderer)
    angle = np.deg2rad(text.get_rotation())
    if np.isclose(np.sin(2 * angle), 0.0):
        corners = box.padded(-0.5).corners()[[0, 1, 3, 2]]
    else:
        clean, ismath = text._preprocess_math(text.get_text())
        width, height, _ = renderer.get_text_width_height_descent(clean, text.get_fontproperties(), ismath)
        half = np.array([[-1, -1], [-1, 1], [1, 1], [1, -1]]) * ([width / 2 - 0.5, height / 2 - 0.5])
        turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        corners = half @ turn.T + [(box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2]
    return matplotlib.path.Path(np.vstack([corners, corners[:1]]), closed=True)


@pytest.mark.parametrize("name", ITEMS_DRAWINGS)
def test_an_items_figure_speaks_in_words_and_ticks_whole_numbers_on_whole_number_axes(items_figures, name):
    fig, _ = items_figures[name]
    texts = shown_texts(fig)
    words = [re.sub(r"\$[^$]*\$", "", text.get_text()) for text in texts]  # mathtext names a symbol, not a key
    for text in words:
        assert not any(column in text for column in iexperiments.CONFIG_COLUMNS if "_" in column), text
        assert not re.search(r"\w=\S", text), text  # "capacity c = 5", never "key=value"
    drawn = {id(text) for text in texts}
    for ax in fig.axes:
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if label.startswith(("robots n", "capacity c")):
                shown = [tick.label1.get_text() for tick in axis.get_major_ticks() if id(tick.label1) in drawn]
                assert shown and all(re.fullmatch(r"\d+", label) for label in shown), (label, shown)


@pytest.mark.parametrize("name", [name for name in ITEMS_DRAWINGS if name[:len("items-figNN")] in istudy.SURFACES])
def test_a_3d_figure_draws_wireframes_in_the_legends_colours_beside_heat_maps_on_one_scale(items_figures, name):
    fig, _ = items_figures[name]
    legend = {text.get_text(): handle.get_color() for legend in fig.legends
              for text, handle in zip(legend.get_texts(), legend.legend_handles)}
    three_d = [ax for ax in fig.axes if ax.name == "3d"]
    assert three_d
    for ax in three_d:
        wires = ax.collections
        assert len(wires) == len(legend)
        for wire, colour in zip(wires, legend.values()):
            assert isinstance(wire, mplot3d.art3d.Line3DCollection)  # lines: no surface hides another
            assert wire.get_alpha() in (None, 1.0)
            assert matplotlib.colors.same_color(wire.get_color()[0], colour)
    assert len({ax.get_zlim() for ax in three_d}) == 1  # one z scale in every row (Fig 7: every sigma_e)
    meshes = [artist for ax in fig.axes if ax.get_label() != "<colorbar>" for artist in ax.collections
              if isinstance(artist, matplotlib.collections.QuadMesh)]
    assert len(meshes) == len(legend) * len(three_d)  # a heat map per algorithm and row
    assert len({(mesh.norm.vmin, mesh.norm.vmax) for mesh in meshes}) == 1  # one colour scale
    assert {ax.get_zlim()[0] for ax in three_d} == {meshes[0].norm.vmin}


@pytest.mark.parametrize("figure", ITEMS_FIGURES)
def test_an_items_figures_panels_are_lettered_as_the_paper_and_its_caption_letter_them(items_figures, figure):
    paper = {"items-fig04": 4, "items-fig06": 4, "items-fig07": 4, "items-fig08": 4, "items-fig09": 2,
             "items-fig10": 4, "items-fig11": 4, "items-fig12": 2}  # Fig 12: n = 5 (the paper's) and n = 10
    expected = [f"({letter})" for letter in string.ascii_lowercase[:paper.get(figure, 0)]]
    assert caption_letters(figure) == expected
    for name in items_names(figure):
        fig, _ = items_figures[name]
        renderer = fig.canvas.get_renderer()
        letters = [text for text in shown_texts(fig) if re.fullmatch(r"\([a-z]\)", text.get_text())]
        placed = sorted(letters, key=lambda text: (-round(text.get_window_extent(renderer).y0 / 20),
                                                   text.get_window_extent(renderer).x0))
        assert [text.get_text() for text in placed] == expected, name
        assert all(text.get_fontweight() == "bold" for text in placed)


def test_results_readme_embeds_every_items_figure_with_its_caption_and_names_every_variant():
    text = (ROOT / "results" / "README.md").read_text()
    items = re.search(r"^### Items: figures$.*?(?=^## )", text, re.S | re.M).group(0)
    for figure in ITEMS_FIGURES:
        assert f"]({figure}/{figure}.png)" in items, figure
        assert len(caption(figure).split()) > 20, figure
        for name in items_names(figure):
            assert f"{name}.png" in items, name
