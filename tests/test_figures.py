"""Figures: PNG, PDF and SVG per table, the same bytes for the same table, no titles, the
shared style, no simulator, no pyplot, no user style."""

import ast
import sys
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dronefleet import figstyle
from dronefleet.delivery import figures

matplotlib = pytest.importorskip("matplotlib")

#: How each format's file starts.
MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "pdf": b"%PDF-", "svg": b"<?xml"}


def outcomes():
    rng = np.random.default_rng(0)
    rows = [(rule, tau, seed) for rule in ("least_confident", "random") for tau in (15.0, 30.0) for seed in range(5)]
    frame = pd.DataFrame(rows, columns=["rule", "tau_minutes", "seed"])
    return frame.assign(delivered=rng.integers(1000, 3000, len(frame)),
                        median_delivery_time_s=rng.uniform(600.0, 6000.0, len(frame)),
                        aborted_pct=rng.uniform(5.0, 30.0, len(frame)))


def backlog():
    rows = [(rule, tau, seed, week) for rule in ("least_confident", "random") for tau in (15.0, 30.0)
            for seed in range(3) for week in (1, 2, 3)]
    frame = pd.DataFrame(rows, columns=["rule", "tau_minutes", "seed", "arrival_week"])
    rng = np.random.default_rng(1)
    return frame.assign(pending=rng.integers(0, 50, len(frame)), backlog_age_s=rng.uniform(0.0, 1e7, len(frame)))


def accuracy():
    weeks = np.arange(1, 5)
    return pd.concat([pd.DataFrame({"rule": rule, "week": weeks, "uavs": 500, "mean_accuracy": 0.6 + shift + 0.05 * weeks,
                                    "ci_low": 0.58 + shift + 0.05 * weeks, "ci_high": 0.62 + shift + 0.05 * weeks,
                                    "confidence": 0.95})
                      for rule, shift in (("least_confident", 0.05), ("random", 0.0))], ignore_index=True)


def winner_grid():
    soc, distance, mass = (a.ravel() for a in np.meshgrid([50.0, 100.0], [1000.0, 2000.0, 3000.0], [0.5, 1.0],
                                                          indexing="ij"))
    soh = np.where(distance * mass > 2500.0, np.nan, 0.5 + distance / 6000.0)  # nobody bids on the far heavy ones
    return pd.DataFrame({"soc": soc, "distance_m": distance, "mass_kg": mass, "mean_winner_soh": soh,
                         "runs_with_winner": 3, "runs": 3})


DRAWINGS = {
    "rule_outcomes": (lambda table, path: figures.rule_outcomes(table, backlog(), path), outcomes, "delivered"),
    "delivered_vs_delivery_time": (figures.delivered_vs_delivery_time, outcomes, "delivered"),
    "aborted_by_tau": (figures.aborted_by_tau, outcomes, "aborted_pct"),
    "backlog_bars": (figures.backlog_bars, backlog, "backlog_age_s"),
    "accuracy_over_weeks": (figures.accuracy_over_weeks, accuracy, "mean_accuracy"),
    "winner_soh_heatmaps": (figures.winner_soh_heatmaps, winner_grid, "mean_winner_soh"),
    "pending_bars": (figures.pending_bars, lambda: backlog()[lambda f: f["tau_minutes"] == 15.0], "pending"),
}


@pytest.mark.parametrize("name", DRAWINGS)
def test_a_table_gives_each_format_with_the_same_bytes_every_time_and_the_data_shows(name, tmp_path, monkeypatch):
    draw, table, column = DRAWINGS[name]
    import dronefleet.delivery.simulation

    def no_simulation(*args, **kwargs):
        raise AssertionError("a figure must not simulate")

    monkeypatch.setattr(dronefleet.delivery.simulation, "simulate", no_simulation)
    first = draw(table(), tmp_path / "first.png")
    assert first == [tmp_path / f"first.{suffix}" for suffix in ("png", "pdf", "svg")]
    second = draw(table(), tmp_path / "second.png")
    for path, again in zip(first, second):
        data = path.read_bytes()
        assert data.startswith(MAGIC[path.suffix[1:]]) and len(data) > 10_000, path.name
        assert data == again.read_bytes(), path.name
        # no Software / Creator / Producer entry (they name the version), no date
        assert b"matplotlib v" not in data.lower() and b"matplotlib version" not in data.lower(), path.name
        assert b"CreationDate" not in data and b"<dc:date>" not in data, path.name
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in first + second)  # no leftovers
    changed = table()
    changed[column] = changed[column] * 1.5
    assert draw(changed, tmp_path / "changed")[0].read_bytes() != first[0].read_bytes()


def test_no_figure_has_a_title(tmp_path, drawn_figures):
    kept = drawn_figures(figures)
    for name, (draw, table, _) in DRAWINGS.items():
        draw(table(), tmp_path / name)
    assert len(kept) == len(DRAWINGS)
    for fig in kept:
        assert fig._suptitle is None or fig._suptitle.get_text() == ""
        assert all(ax.get_title(loc) == "" for ax in fig.axes for loc in ("left", "center", "right"))


def test_each_rule_keeps_the_studys_colour_and_its_own_marker_and_line_style(tmp_path, drawn_figures):
    green, pink, orange = "#009E73", "#CC79A7", "#E69F00"  # least_confident, most_confident, random
    table = pd.concat([accuracy(), accuracy().query("rule == 'random'").assign(rule="most_confident")])
    kept = drawn_figures(figures)
    figures.accuracy_over_weeks(table, tmp_path / "fig")
    lines = {line.get_label().split()[0]: line for line in kept[0].axes[0].lines}
    assert {rule: line.get_color() for rule, line in lines.items()} == {
        "least_confident": green, "most_confident": pink, "random": orange}
    assert len({line.get_marker() for line in lines.values()}) == 3  # apart in greyscale too
    assert len({line.get_linestyle() for line in lines.values()}) == 3


def test_styles_of_baselines_and_unknown_rules_are_all_different():
    chosen = figstyle.styles(["threshold(80)", "least_confident", "reservation", "mine", "yours"],
                             figstyle.RULE_STYLES)
    assert chosen["threshold(80)"] == figstyle.RULE_STYLES["threshold"]
    assert len(set(chosen.values())) == 5 and len({style.colour for style in chosen.values()}) == 5
    assert figstyle.styles(["fixed", "mobile"], figstyle.STRATEGY_STYLES)["fixed"].colour != \
        figstyle.styles(["fixed", "mobile"], figstyle.STRATEGY_STYLES)["mobile"].colour


def test_tau_labels_of_coinciding_boxes_are_written_once_and_none_overlap(tmp_path, drawn_figures):
    # At tau 30 and 35 both rules have the same runs (their boxes coincide, as at light load
    # in Fig. 16a); at tau 15 they are far apart.
    frame = outcomes()
    same = frame["tau_minutes"] == 30.0
    frame.loc[same & (frame["rule"] == "random"), ["delivered", "median_delivery_time_s"]] = \
        frame.loc[same & (frame["rule"] == "least_confident"), ["delivered", "median_delivery_time_s"]].to_numpy()
    frame.loc[(frame["rule"] == "random") & ~same, "median_delivery_time_s"] += 50_000.0
    kept = drawn_figures(figures)
    figures.delivered_vs_delivery_time(frame, tmp_path / "fig")
    fig = kept[0]
    labels = fig.axes[0].texts
    assert sorted(text.get_text() for text in labels) == ["15", "15", "30"]
    (shared,) = [text for text in labels if text.get_text() == "30"]
    assert matplotlib.colors.to_hex(shared.get_color()) == "#000000"
    renderer = fig.canvas.get_renderer()
    for a, b in combinations(labels, 2):
        assert not a.get_window_extent(renderer).overlaps(b.get_window_extent(renderer))


def test_a_figure_is_laid_out_once_for_all_its_formats_and_its_png_is_savefigs_own(tmp_path, monkeypatch):
    # savefig lays a figure out again in a dry draw per format: half of the drawing time
    layouts = []
    from matplotlib.layout_engine import ConstrainedLayoutEngine as engine
    execute = engine.execute
    monkeypatch.setattr(engine, "execute", lambda self, fig: layouts.append(fig) or execute(self, fig))

    def draw(ax):
        ax.plot([0.0, 1.0, 2.0], [3.0, 1.0, 2.0], marker="o", label="a line")
        ax.set_xlabel("x label")
        ax.set_ylabel("y label")
        ax.legend()

    with figstyle._figure(tmp_path / "once", (3.5, 2.5)) as (mpl, _, ax):
        draw(ax)
    assert len(layouts) == 1
    with mpl.style.context(["default", figstyle.RC]):  # as savefig lays it out for a PNG alone
        fig = mpl.figure.Figure(figsize=(3.5, 2.5), layout="constrained")
        draw(fig.subplots())
        fig.savefig(tmp_path / "savefig.png", dpi=figstyle.DPI, metadata=figstyle._NO_STAMPS["png"])
    assert (tmp_path / "once.png").read_bytes() == (tmp_path / "savefig.png").read_bytes()


def test_the_users_matplotlib_style_changes_nothing(tmp_path):
    before = [path.read_bytes() for path in figures.aborted_by_tau(outcomes(), tmp_path / "before")]
    with matplotlib.rc_context({"lines.linewidth": 7.0, "axes.facecolor": "red", "font.size": 20,
                                "svg.hashsalt": "mine"}):
        styled = [path.read_bytes() for path in figures.aborted_by_tau(outcomes(), tmp_path / "styled")]
        assert matplotlib.rcParams["lines.linewidth"] == 7.0  # and the user's settings stay
    assert styled == before


def test_figures_import_nothing_of_the_simulator_and_leave_no_pyplot_figures(tmp_path):
    # Imports only the standard library, numpy, pandas, (lazily) matplotlib and the shared style,
    # which imports of dronefleet only its output errors (outputs, config: no engine): drawing cannot
    # load the engine.
    def imported(module):
        tree = ast.parse(Path(module.__file__).read_text())
        names = {alias.name.split(".")[0] for node in ast.walk(tree) if isinstance(node, ast.Import)
                 for alias in node.names}
        return names | {node.module.split(".")[0] if node.level == 0 else "." * node.level + node.module
                        for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}

    def outside_stdlib(module):
        return {name for name in imported(module) if name not in sys.stdlib_module_names}

    assert outside_stdlib(figures) == {"numpy", "pandas", "..figstyle"}
    assert outside_stdlib(figstyle) == {"matplotlib", ".outputs"}
    figures.accuracy_over_weeks(accuracy(), tmp_path / "fig")
    # matplotlib itself may import pyplot (to resolve its default backend), but no figure is left there.
    if "matplotlib.pyplot" in sys.modules:
        assert sys.modules["matplotlib.pyplot"].get_fignums() == []


def test_without_matplotlib_the_error_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r"a dependency of dronefleet: pip install matplotlib"):
        figures.aborted_by_tau(outcomes(), tmp_path / "fig")
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("folder", ["missing", "a-file"])
def test_a_figure_into_a_folder_that_is_not_there_is_one_line_before_drawing(folder, tmp_path):
    from dronefleet.config import ConfigError

    (tmp_path / "a-file").write_text("")
    with pytest.raises(ConfigError) as refused:
        figures.aborted_by_tau(outcomes(), tmp_path / folder / "fig")
    message = str(refused.value)
    assert "\n" not in message and str(tmp_path / folder) in message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


def test_threshold_table_files(tmp_path):
    table = pd.DataFrame({"theta": [50.0, 80.0], "runs": [120, 120], "delivered_mean": [2500.25, 3100.0],
                          "delivered_median": [2490.0, 3105.5], "median_delivery_time_s": [5400.0, 1800.0],
                          "aborted_pct_mean": [12.5, 1.25], "pending_mean": [800.0, 200.0],
                          "backlog_age_s_mean": [86_400.0 * 30, 86_400.0 * 3], "best": [False, True]})
    csv, md = figures.write_threshold_table(table, tmp_path / "thresholds.png")
    assert (csv.name, md.name) == ("thresholds.csv", "thresholds.md")
    pd.testing.assert_frame_equal(pd.read_csv(csv), table)
    lines = md.read_text().splitlines()
    assert lines[0].startswith("| theta (%) | runs | delivered (mean) |")
    assert lines[2] == "| 50 | 120 | 2500.2 | 2490.0 | 90.0 | 12.50 | 800.0 | 30.0 |  |"
    assert lines[3] == "| 80 | 120 | 3100.0 | 3105.5 | 30.0 | 1.25 | 200.0 | 3.0 | yes |"


@pytest.mark.parametrize("name", DRAWINGS)
def test_each_drawing_is_a_column_or_page_wide_with_no_text_below_7_pt(name, tmp_path, drawn_figures):
    # the panels drawn alone too, not only the study's figures (tests/test_paper_figures.py)
    draw, table, _ = DRAWINGS[name]
    kept = drawn_figures(figures)
    draw(table(), tmp_path / name)
    (fig,) = kept
    assert fig.get_size_inches()[0] in (figstyle.SINGLE_COLUMN, figstyle.DOUBLE_COLUMN)
    sizes = [text.get_fontsize() for text in fig.findobj(matplotlib.text.Text) if text.get_text().strip()]
    assert sizes and min(sizes) >= figstyle.MIN_FONT_SIZE


def test_the_log_axis_of_delivery_times_reads_plain_minutes_on_a_narrow_range(tmp_path, drawn_figures):
    # A user's small sweep: every median between 6 and 9 min, so the labelled ticks are minor
    # ones, which read "6x10^0" in scientific notation
    frame = outcomes().assign(median_delivery_time_s=lambda f: np.linspace(360.0, 540.0, len(f)))
    kept = drawn_figures(figures)
    figures.delivered_vs_delivery_time(frame, tmp_path / "fig")
    axis = kept[0].axes[0].xaxis
    labels = [label.get_text() for label in [*axis.get_ticklabels(), *axis.get_ticklabels(minor=True)]]
    shown = [text for text in labels if text]
    assert len(shown) >= 2 and all(float(text) > 0 for text in shown), shown
