"""``dronefleet replay DATASET --run KEY=VALUE ...``: one run of a sweep's dataset, played from its
parts or, if its tables were not kept, simulated again from its stored config; a selection that
names no run or several is refused in one line listing what is allowed, before anything is written."""

import shutil

import pyarrow.parquet as pq
import pytest
from test_replay import _refused, embedded, first_set, tamper_table

from dronefleet import cli
from dronefleet.replay import DATASET_PAGES

DELIVERY = """[sweep]
name = "ds"
seeds = [0, 1]
[set]
horizon_weeks = 0.05
n_uavs = 3
[grid]
rule = ["least_confident", "random"]
"""
REPLENISHMENT = """[sweep]
name = "rs"
scenario = "replenishment"
[set]
trials = 2
ticks = 300
[grid]
work_ratio = [0.5, 1.0]
"""


def _sweep(folder, text):
    (folder / "sweep.toml").write_text(text)
    assert cli.main(["-q", "sweep", "run", str(folder / "sweep.toml"), "--results", str(folder), "--jobs", "1"]) == 0


@pytest.fixture(scope="module")
def delivery_dataset(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    _sweep(folder, DELIVERY)
    return folder / "ds"


@pytest.fixture
def dataset(delivery_dataset, tmp_path):
    """A copy of the delivery dataset, free to change."""
    return shutil.copytree(delivery_dataset, tmp_path / "ds")


RUN = ["--run", "rule=random", "--run", "seed=1"]
PART = "rule=random/seed=1/part-0.parquet"


def test_a_run_is_chosen_by_its_grid_values_and_seed(dataset, capsys):
    assert cli.main(["replay", str(dataset), *RUN]) == 0
    page = dataset / DATASET_PAGES / "rule=random,seed=1.html"
    assert str(page) in capsys.readouterr().out
    data = embedded(page)
    assert data["title"].startswith("delivery run: seed 1, rule random")
    assert data["source"] == "sweep dataset ds, run rule=random/seed=1" and data["title"].endswith(f"({data['source']})")
    assert len(data["flights"]["takeoff_s"]) == pq.ParquetFile(dataset / "attempts" / PART).metadata.num_rows
    # a number names the value whatever its spelling, a key its section too
    assert cli.main(["replay", str(dataset), "--run", "auction.rule=random", "--run", "seed=1.0",
                     "--out", str(dataset.parent / "page.html")]) == 0
    assert embedded(dataset.parent / "page.html") == data


def test_a_run_whose_tables_were_not_kept_is_simulated_again_from_its_config(dataset, capsys):
    kept = dataset.parent / "kept.html"
    assert cli.main(["replay", str(dataset), *RUN, "--out", str(kept)]) == 0
    for table in ("orders", "attempts", "fleet", "timeseries"):
        (dataset / table / PART).unlink()
    again = dataset.parent / "again.html"
    assert cli.main(["replay", str(dataset), *RUN, "--out", str(again)]) == 0
    assert "simulating it again from its config" in capsys.readouterr().out
    assert embedded(again) == embedded(kept)


def test_a_summary_the_simulation_does_not_give_again_is_refused(dataset, capsys):
    (dataset / "orders" / PART).unlink()
    tamper_table(dataset / "summary" / PART, first_set("delivered", 10**6))
    _refused(capsys, ["replay", str(dataset), *RUN], f"summary/{PART}': its run simulated again from its config "
                                                      "gives another summary")
    assert not (dataset / DATASET_PAGES).exists()


def test_a_damaged_part_is_named(dataset, capsys):
    orders = dataset / "orders" / PART
    orders.write_bytes(orders.read_bytes()[:100])
    _refused(capsys, ["replay", str(dataset), *RUN], f"orders/{PART}'")
    assert not (dataset / DATASET_PAGES).exists()


@pytest.mark.parametrize("selection, fragment", [
    ([], "it holds 4 runs; choose one with --run KEY=VALUE for rule, seed (rule = least_confident, random; "
         "seed = 0, 1)"),
    (["--run", "rule=random"], "--run rule=random matches 2 runs; choose one with --run KEY=VALUE for seed "
                               "(seed = 0, 1)"),
    (["--run", "rule=random", "--run", "seed=7"], "--run seed=7: no run of the dataset"),
    (["--run", "seed=7"], "allowed: seed = 0, 1"),
    (["--run", "tau_minutes=15"], "are told apart by rule, seed; choose with those"),
    (["--run", "nonsense=1"], "are told apart by rule, seed"),
    (["--run", "rule"], "--run 'rule': expected KEY=VALUE, one of the keys rule, seed"),
    (["--run", "seed=0", "--run", "seed=1"], "--run seed is given twice"),
])
def test_a_selection_naming_no_run_or_several_is_refused_in_one_line(selection, fragment, dataset, capsys):
    _refused(capsys, ["replay", str(dataset), *selection], fragment)
    assert not (dataset / DATASET_PAGES).exists()


def test_run_is_refused_on_a_run_folder_and_pages_never_go_among_the_parts(dataset, tmp_path, capsys):
    run = tmp_path / "run"
    assert cli.main(["run", "--set", "horizon_weeks=0.01", "--set", "n_uavs=2", "--out", str(run)]) == 0
    _refused(capsys, ["replay", str(run), "--run", "seed=0"], f"--run chooses a run of a sweep's dataset; {str(run)!r} is a run folder")
    _refused(capsys, ["replay", str(dataset), *RUN, "--out", str(dataset / "summary" / "page.html")],
             "lies in the dataset's summary files")
    _refused(capsys, ["replay", str(tmp_path / "absent"), *RUN], "holds no sweep dataset")
    _refused(capsys, ["replay", str(dataset), *RUN, "--trial", "2"], "--trial 2: a delivery run is one replicate")
    assert not (dataset / DATASET_PAGES).exists() and not (dataset / "summary" / "page.html").exists()


def test_a_part_moved_to_another_runs_folder_is_refused(dataset, capsys):
    shutil.copy(dataset / "summary" / "rule=random/seed=0/part-0.parquet", dataset / "summary" / PART)
    _refused(capsys, ["replay", str(dataset), *RUN], "holds the config of run rule=random/seed=0, not of the folder")


def test_a_trial_of_a_replenishment_sweeps_run(tmp_path, capsys):
    _sweep(tmp_path, REPLENISHMENT)
    dataset, page = tmp_path / "rs", tmp_path / "page.html"
    assert cli.main(["replay", str(dataset), "--run", "work_ratio=1", "--trial", "2", "--out", str(page)]) == 0
    data = embedded(page)
    summary = pq.read_table(dataset / "summary" / "work_ratio=1.0/part-0.parquet").to_pandas()
    assert data["source"] == "sweep dataset rs, run work_ratio=1.0"
    assert "trial 2 of" in data["title"] and data["work"][-1] == summary.set_index("trial").loc[2, "work"]
    _refused(capsys, ["replay", str(dataset), "--run", "work_ratio=1", "--trial", "3", "--out", str(page)],
             "--trial 3: the run holds trials 1 to 2")


def test_only_the_chosen_runs_part_is_read(dataset, capsys):
    # another run's summary cut short: that run is not the one asked for
    other = dataset / "summary" / "rule=random/seed=0/part-0.parquet"
    other.write_bytes(other.read_bytes()[:50])
    assert cli.main(["replay", str(dataset), *RUN]) == 0
    _refused(capsys, ["replay", str(dataset), "--run", "rule=random", "--run", "seed=0"],
             "rule=random/seed=0/part-0.parquet")


def test_folder_names_are_shown_on_one_line(dataset, capsys):
    odd = dataset / "summary" / "rule=a%0Ab%1B[31m" / "seed=0"
    odd.mkdir(parents=True)
    shutil.copy(dataset / "summary" / PART, odd / "part-0.parquet")
    _refused(capsys, ["replay", str(dataset), "--run", "rule=x"], "rule = a b\\x1b[31m, least_confident, random")


LUNAR = """[sweep]
name = "ls"
scenario = "lunar"
[set]
runs = 1
n_robots = 10
duration_s = 30.0
[grid]
layout = ["OPEN", "SOFT-RT"]
battery_wh = [5.0]
"""


def test_a_run_of_a_sweep_over_keys_its_summary_holds_is_played_with_them_put_back(tmp_path, capsys):
    # lunar's summary holds layout and battery_wh: a part leaves them out (they are in its path)
    _sweep(tmp_path, LUNAR)
    dataset = tmp_path / "ls"
    kept, again = tmp_path / "kept.html", tmp_path / "again.html"
    assert cli.main(["replay", str(dataset), "--run", "battery_wh=5.0", "--run", "layout=OPEN",
                     "--out", str(kept)]) == 0
    assert "layout" not in pq.read_schema(dataset / "summary" / "battery_wh=5.0/layout=OPEN/root_seed=0/part-0.parquet").names
    for table in ("timeseries", "trips", "snapshots"):  # the run simulated again gives the same page
        (dataset / table / "battery_wh=5.0/layout=OPEN/root_seed=0/part-0.parquet").unlink()
    assert cli.main(["replay", str(dataset), "--run", "layout=OPEN", "--run", "battery_wh=5", "--out", str(again)]) == 0
    assert embedded(kept) == embedded(again)
    assert embedded(kept)["source"] == "sweep dataset ls, run battery_wh=5.0/layout=OPEN/root_seed=0"
