"""Figure style shared by every scenario's figures: matplotlib loaded on demand, one figure
on the Agg canvas under matplotlib's default style, saved reproducibly.

matplotlib is an optional dependency (``pip install 'dronefleet[plots]'``), imported
only when a figure is drawn. Figures are ``matplotlib.figure.Figure`` objects on the Agg
canvas, never pyplot, so nothing stays registered in pyplot's global state; they are
drawn under matplotlib's default style whatever the user's matplotlibrc, and saved
without the "Software" entry, so the same table gives the same bytes.
"""

from contextlib import contextmanager

DPI = 150


def require_matplotlib():
    """The matplotlib package with the submodules used here, or an error that says how to install it."""
    try:
        import matplotlib
        import matplotlib.backends.backend_agg
        import matplotlib.cbook
        import matplotlib.figure
        import matplotlib.patches
        import matplotlib.style
        import matplotlib.ticker
    except ImportError as error:
        raise ImportError("drawing figures needs matplotlib: pip install 'dronefleet[plots]'") from error
    return matplotlib


@contextmanager
def _figure(path, title, figsize, **subplots):
    """A new figure and its axes (``Figure.subplots(**subplots)``), saved to ``path`` on exit."""
    mpl = require_matplotlib()
    # The default style also while saving: rcParams are read when artists are drawn.
    with mpl.style.context("default"):
        fig = mpl.figure.Figure(figsize=figsize, layout="constrained")
        mpl.backends.backend_agg.FigureCanvasAgg(fig)
        axes = fig.subplots(**subplots)
        yield mpl, fig, axes
        fig.suptitle(title)
        fig.savefig(path, dpi=DPI, format="png", metadata={"Software": None})


def _dodge(k, n, width):
    """Offset of the k-th of n side-by-side items of ``width``, so that together they centre on 0."""
    return (k - (n - 1) / 2) * width
