"""Figure style shared by every scenario's figures: matplotlib loaded on demand, one figure
on the Agg canvas in the project's style, saved reproducibly as PNG, PDF and SVG.

matplotlib is imported only when a figure is drawn, so a run never loads it. Figures are
``matplotlib.figure.Figure`` objects on the Agg canvas, never pyplot, so nothing stays
registered in pyplot's global state; they are drawn under matplotlib's default style plus
:data:`RC`, whatever the user's matplotlibrc, and saved without dates or software versions,
so the same table gives the same bytes in every format.

Each winner rule, replenishment strategy and items algorithm has one :class:`Style` in every figure:
the study's colours (least_confident green, most_confident pink, random orange) from the
Okabe-Ito palette, which stays distinct under the common colour-vision deficiencies, and a
marker, line style and hatch of its own, so that lines and boxes stay apart in greyscale
too. Figures have no titles: their captions live in ``results/README.md``.

The studies' figures are drawn at print size, as wide as a journal column
(:data:`SINGLE_COLUMN`) or page (:data:`DOUBLE_COLUMN`), under :data:`PRINT_RC`, so that no text
is smaller than :data:`MIN_FONT_SIZE` in print; a figure of several panels is one file, its
panels lettered (a), (b), ... by :func:`letter_panels` as the captions letter them.
"""

import contextvars
import itertools
import os
import string
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

from .outputs import OutputError, writing

DPI = 150
#: Widths (in) of a figure that fills one journal column, or both (the page's text width).
SINGLE_COLUMN = 3.5
DOUBLE_COLUMN = 7.2
#: The smallest font size (pt) of any text of a study figure, printed at its own width.
MIN_FONT_SIZE = 7.0
#: The formats every figure is written in, side by side (same name, these suffixes).
FORMATS = ("png", "pdf", "svg")
#: Okabe & Ito's colour-blind-safe palette (Color Universal Design), by name.
OKABE_ITO = {"orange": "#E69F00", "sky blue": "#56B4E9", "bluish green": "#009E73", "yellow": "#F0E442",
             "blue": "#0072B2", "vermillion": "#D55E00", "reddish purple": "#CC79A7", "black": "#000000"}
#: What the writers would otherwise stamp into a file: dates and software versions.
_NO_STAMPS = {"png": {"Software": None}, "pdf": {"Creator": None, "Producer": None, "CreationDate": None},
              "svg": {"Creator": None, "Date": None}}


class Style(NamedTuple):
    """How one rule or strategy is drawn: ``colour`` for fills and lines, ``marker`` for
    points, ``linestyle`` for lines and whiskers, ``hatch`` for boxes and bars."""
    colour: str
    marker: str
    linestyle: object
    hatch: str


#: Winner rules: the study's colours for its three rules, clear others for the baselines.
RULE_STYLES = {
    "least_confident": Style(OKABE_ITO["bluish green"], "o", "-", ""),
    "most_confident": Style(OKABE_ITO["reddish purple"], "s", "--", "//"),
    "random": Style(OKABE_ITO["orange"], "^", ":", ".."),
    "threshold": Style(OKABE_ITO["blue"], "D", "-.", "xx"),
    "reservation": Style(OKABE_ITO["vermillion"], "v", (0, (5, 1, 1, 1)), "\\\\"),
}
#: Replenishment strategies: fixed chargers in the base, mobile chargers.
STRATEGY_STYLES = {
    "fixed": Style(OKABE_ITO["blue"], "s", "-", "//"),
    "mobile": Style(OKABE_ITO["vermillion"], "o", "-", ""),
}
#: The items study's algorithms (Liemhetcharat et al.): one of the palette's colours each.
ALGORITHM_STYLES = {
    "R": Style(OKABE_ITO["orange"], "^", ":", ".."),
    "GR": Style(OKABE_ITO["blue"], "o", "-", ""),
    "GRIC": Style(OKABE_ITO["sky blue"], "D", "-.", "xx"),
    "CAS": Style(OKABE_ITO["vermillion"], "s", "--", "//"),
    "AS": Style(OKABE_ITO["bluish green"], "v", "-", "\\\\"),
    "ASTC": Style(OKABE_ITO["reddish purple"], "P", "-.", "oo"),
    "SF": Style(OKABE_ITO["black"], "X", (0, (1, 2)), "++"),
}
#: For names no table above knows (a plugin rule), in sorted order of those names.
_OTHER_STYLES = (Style(OKABE_ITO["sky blue"], "P", (0, (3, 1, 1, 1, 1, 1)), "++"),
                 Style(OKABE_ITO["black"], "X", (0, (1, 2)), "oo"),
                 Style(OKABE_ITO["yellow"], "*", (0, (8, 2)), "--"))
#: Settings on top of matplotlib's default style. The SVG ids derive from a fixed salt instead
#: of a random one; PDFs embed TrueType fonts (type 42), which journals accept, not type 3;
#: anything drawn in the default colour cycle takes the palette too.
RC = {"svg.hashsalt": "dronefleet", "pdf.fonttype": 42,
      "axes.prop_cycle": f"cycler(color={[style.colour for style in RULE_STYLES.values()]!r})"}
#: On top of :data:`RC` for figures drawn at print size: text of 7-8 pt (none below
#: :data:`MIN_FONT_SIZE`), lines, ticks and hatches thin enough for a column's width.
PRINT_RC = {"font.size": 8.0, "axes.labelsize": 8.0, "xtick.labelsize": MIN_FONT_SIZE,
            "ytick.labelsize": MIN_FONT_SIZE, "legend.fontsize": MIN_FONT_SIZE,
            "legend.title_fontsize": MIN_FONT_SIZE, "axes.linewidth": 0.6, "lines.linewidth": 1.0,
            "lines.markersize": 4.0, "patch.linewidth": 0.6, "hatch.linewidth": 0.5,
            "xtick.major.width": 0.6, "ytick.major.width": 0.6, "xtick.major.size": 2.5,
            "ytick.major.size": 2.5, "legend.handlelength": 1.8, "legend.borderaxespad": 0.3,
            "legend.columnspacing": 1.2, "figure.constrained_layout.h_pad": 0.03,
            "figure.constrained_layout.w_pad": 0.03}
#: Font size (pt) of the panel letters, bold: the largest text of a figure.
PANEL_LETTER_SIZE = 9.0


def styles(names: Iterable[str], known: Mapping[str, Style]) -> dict[str, Style]:
    """The :class:`Style` of each of ``names`` (one per distinct name, in sorted order).

    A name is looked up in ``known`` by its part before any parenthesis (``threshold(80)``
    is drawn as ``threshold``); names not there take :data:`_OTHER_STYLES` in turn.
    """
    others = itertools.cycle(_OTHER_STYLES)
    return {name: known.get(str(name).partition("(")[0]) or next(others) for name in sorted(set(names))}


def require_matplotlib() -> ModuleType:
    """The matplotlib package with the submodules used here, or an error that says how to install it."""
    try:
        import matplotlib
        import matplotlib.backends.backend_agg
        import matplotlib.cbook
        import matplotlib.figure
        import matplotlib.legend_handler
        import matplotlib.lines
        import matplotlib.patches
        import matplotlib.style
        import matplotlib.ticker
        import matplotlib.transforms
    except ImportError as error:
        raise ImportError("drawing figures needs matplotlib, a dependency of dronefleet: "
                          "pip install matplotlib") from error
    return matplotlib


def figure_paths(path: str | os.PathLike) -> list[Path]:
    """The files a figure named ``path`` is written to: its name with each of :data:`FORMATS`."""
    path = Path(path)
    return [path.with_suffix(f".{suffix}") for suffix in FORMATS]


def letter_panels(axes: Iterable[Any]) -> None:
    """Letter the panels ``axes`` (matplotlib Axes, in the order their caption names them) (a),
    (b), ...: bold, :data:`PANEL_LETTER_SIZE` pt, just above each one's upper left corner,
    outside the data."""
    for letter, ax in zip(string.ascii_lowercase, axes):
        ax.annotate(f"({letter})", (0.0, 1.0), xycoords="axes fraction", xytext=(-2.0, 5.0),
                    textcoords="offset points", ha="right", va="bottom", fontsize=PANEL_LETTER_SIZE,
                    fontweight="bold")


#: The mark of the figures drawn now, or "": ``reproduce --quick`` sets what its runs were (:func:`marked`).
_MARK: contextvars.ContextVar[str] = contextvars.ContextVar("dronefleet_figure_mark", default="")


@contextmanager
def marked(what: str) -> Iterator[None]:
    """Mark every figure drawn within as a quick check (``what``: its small runs, e.g. "2 trials of 200
    ticks"): a large translucent "QUICK CHECK" across it and a line saying what it ran, so that it is
    never taken for a published figure."""
    token = _MARK.set(what)
    try:
        yield
    finally:
        _MARK.reset(token)


def _stamp(fig) -> None:
    """:func:`marked`'s mark on ``fig`` (after the layout: it overlays the drawing, moving nothing)."""
    what = _MARK.get()
    if what:
        fig.text(0.5, 0.5, "QUICK CHECK", ha="center", va="center", rotation=25, fontsize=44, color="#c00000",
                 alpha=0.22, fontweight="bold", zorder=100)
        fig.text(0.5, 0.22, f"{what}: not the published figure", ha="center", va="center", fontsize=8,
                 color="#c00000", zorder=100, bbox={"facecolor": "white", "edgecolor": "#c00000", "alpha": 0.8})


@contextmanager
def _figure(path, figsize, rc=None, mosaic=None, **subplots):
    """A new figure and its axes (``Figure.subplots(**subplots)``, or with ``mosaic`` the dict of
    ``Figure.subplot_mosaic(mosaic, **subplots)``), drawn under :data:`RC` and then ``rc``
    (e.g. :data:`PRINT_RC`), saved on exit to :func:`figure_paths` of ``path`` (any suffix of
    ``path`` is replaced).

    The layout is done once, at :data:`DPI`, and shared by every format (PNG bytes as savefig's
    own layout gives; PDF and SVG differ from a per-format layout by fractions of a point).
    Each file is written to a hidden sibling and renamed into place: a reader never sees
    half a figure.
    """
    folder = Path(path).parent
    if not folder.is_dir():  # before drawing: a user's figure call names a folder that is not there
        raise OutputError(f"cannot write the figure {str(path)!r}: its folder {str(folder)!r} "
                          f"{'is not a folder' if folder.exists() else 'does not exist'}")
    mpl = require_matplotlib()
    # The project's style also while saving: rcParams are read when artists are drawn.
    with mpl.style.context(["default", RC, rc or {}]):
        fig = mpl.figure.Figure(figsize=figsize, layout="constrained")
        mpl.backends.backend_agg.FigureCanvasAgg(fig)
        axes = fig.subplots(**subplots) if mosaic is None else fig.subplot_mosaic(mosaic, **subplots)
        yield mpl, fig, axes
        # The constrained layout once, at the PNG's resolution, for every format: savefig would
        # otherwise lay the figure out again in a dry draw per format (half of the drawing time).
        fig.set_dpi(DPI)
        fig.get_layout_engine().execute(fig)
        fig.set_layout_engine(None)
        _stamp(fig)
        for target, suffix in zip(figure_paths(path), FORMATS):
            tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
            try:
                with writing(target):
                    fig.savefig(tmp, dpi=DPI, format=suffix, metadata=_NO_STAMPS[suffix])
                    os.replace(tmp, target)
            finally:
                tmp.unlink(missing_ok=True)


def _dodge(k, n, width):
    """Offset of the k-th of n side-by-side items of ``width``, so that together they centre on 0."""
    return (k - (n - 1) / 2) * width
