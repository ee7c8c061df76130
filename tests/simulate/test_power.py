"""`viestac study --power` (issue 23): power of every analysis against N from simulated studies on
Dask — the same seed gives the same table with 1 and 2 workers, a rerun resumes without
recomputing, the effect settings are validated and act on the synthetic participants."""

import json
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from server.analysis.load import load
from server.analysis.pvalues import p_values
from server.analysis.run import compute
from server.simulate.effects import parse_settings
from server.simulate.power import power_table, replication_seed, run_power
from server.simulate.power_store import ConfigMismatch
from tests.analysis.thesis_data import Truth, build
from server.ipc.records import State

ROOT = Path(__file__).resolve().parents[2]

# Short enough for CI: task 1's ten angles and three estimation levels, no training or practice
# (a simulated participant takes about 0.3 s of wall time here; the thesis study ~26 s).
SHORT = textwrap.dedent("""
    id = "power-short"
    title = "A short study for the power analysis"
    seed = 5
    participants = 3

    [[tasks]]
    id = "angles"
    scenario = "contact-angle"
    device = "ferrovibe"
    subtask = "angles"
    practice = 0
    training_s = 0

    [[tasks]]
    id = "estimation"
    scenario = "stiffness"
    device = "fingertac"
    subtask = "estimation"
    training_s = 0
    conditions = [{ mode = "estimation", level = 2 }, { mode = "estimation", level = 5 },
                  { mode = "estimation", level = 9 }]
""")


@pytest.fixture
def study_file(tmp_path):
    path = tmp_path / "studies" / "power-short.toml"
    path.parent.mkdir()
    path.write_text(SHORT)
    return path


def stored(out):
    con = sqlite3.connect(out / "replications.sqlite")
    try:
        return con.execute("SELECT n, rep, seed, result_json FROM replications ORDER BY n, rep").fetchall()
    finally:
        con.close()


def p_only(rows):
    return [(n, rep, seed, json.loads(text)["p"]) for n, rep, seed, text in rows]


@pytest.mark.slow
def test_same_seed_same_power_table_with_1_and_2_workers_and_a_rerun_resumes(study_file, tmp_path):
    from distributed import LocalCluster

    one = run_power(study_file, [2, 3], 3, out=tmp_path / "one", seed=7, workers=1)
    assert (one.computed, one.reused) == (6, 0)
    # two workers, on a cluster given by address (--scheduler); K = 2 first, then resumed to 3
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        first = run_power(study_file, [2, 3], 2, out=tmp_path / "two", seed=7, scheduler=cluster.scheduler_address)
        before = stored(tmp_path / "two")
        again = run_power(study_file, [2, 3], 3, out=tmp_path / "two", seed=7, scheduler=cluster.scheduler_address)
    assert (first.computed, first.reused) == (4, 0) and (again.computed, again.reused) == (2, 4)
    after = stored(tmp_path / "two")
    assert set(before) <= set(after), "finished replications are kept as they were, never recomputed"
    assert again.table == one.table
    assert p_only(after) == p_only(stored(tmp_path / "one")), "every replication's p-values, whoever ran it"
    table = json.loads((tmp_path / "one" / "power.json").read_text())["table"]
    assert table == json.loads((tmp_path / "two" / "power.json").read_text())["table"]
    tests = {row["test"] for row in table}
    assert {"task1.rm_anova", "task1.quadratic_trend", "task3.estimation.b"} <= tests
    b = [row for row in table if row["test"] == "task3.estimation.b"]
    assert [row["n"] for row in b] == [2, 3] and all(row["replications"] == 3 for row in b)
    assert all(row["ci95"][0] <= row["power"] <= row["ci95"][1] for row in table)
    assert (tmp_path / "one" / "power.png").stat().st_size > 0 and (tmp_path / "one" / "power.csv").exists()
    # a finished grid reruns without any work (no cluster either), here from the command line
    done = subprocess.run([sys.executable, "-m", "server.cli", "study", "--power", "--study", str(study_file),
                           "--participants", "3,2", "--replications", "3", "--seed", "7", "--out",
                           str(tmp_path / "one")], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert "(0 run now, 6 stored)" in done.stdout and "6/6 replications" in done.stderr
    line = next(t for t in done.stdout.splitlines() if t.startswith("task3.estimation.b "))
    assert [float(v) for v in line.split()[1:]] == [round(row["power"], 2) for row in b]
    assert json.loads((tmp_path / "one" / "power.json").read_text())["table"] == table
    # another configuration is refused
    with pytest.raises(ConfigMismatch, match="seed"):
        run_power(study_file, [2], 1, out=tmp_path / "one", seed=8, workers=1)


def test_replication_seeds_depend_on_seed_n_and_replication_only():
    seeds = {replication_seed(7, n, r) for n in (8, 12, 16) for r in range(50)}
    assert len(seeds) == 150 and all(0 <= s < 2 ** 63 for s in seeds)
    assert replication_seed(7, 12, 3) == replication_seed(7, 12, 3) != replication_seed(8, 12, 3)
    code = "from server.simulate.power import replication_seed as s; print(s(7, 12, 3))"
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           env={"PYTHONHASHSEED": "123"}, cwd=ROOT)
    assert int(other.stdout) == replication_seed(7, 12, 3), "the same in another process"


def test_power_counts_significant_replications_and_a_skipped_test_as_not_significant():
    results = {(4, 0): {"p": {"a": 0.01, "b": 0.2}}, (4, 1): {"p": {"a": 0.049, "b": None}},
               (4, 2): {"p": {"a": 0.05}}, (4, 3): {"p": {"a": 0.5, "b": 0.001}}}
    rows = {(r["test"], r["n"]): r for r in power_table(results, [4], 4, 0.05)}
    assert rows["a", 4]["significant"] == 2 and rows["a", 4]["power"] == 0.5 and rows["a", 4]["ran"] == 4
    assert rows["b", 4]["significant"] == 1 and rows["b", 4]["power"] == 0.25 and rows["b", 4]["ran"] == 2
    low, high = rows["a", 4]["ci95"]
    assert 0.05 < low < 0.5 < high < 0.95, "Clopper-Pearson of 2 in 4"


def test_effect_settings_are_validated_and_reach_the_participants():
    people = parse_settings(["agent.ferrovibe.duration_scale=1.3", "estimation.b=0.9", "agent.endpoint_noise=0.08"])
    assert people.agent["ferrovibe"].duration_scale == 1.3 and people.agent["fingertac"].duration_scale == 1.0
    assert people.agent["ferrovibe"].endpoint_noise == people.agent["fingertac"].endpoint_noise == 0.08
    assert people.participant(1, 0).models.estimation.b == 0.9
    same = parse_settings(["agent.endpoint_noise=0.08", "estimation.b=0.9", "agent.ferrovibe.duration_scale=1.3"])
    assert same.settings == people.settings, "order does not matter"
    device_wins = parse_settings(["agent.ferrovibe.duration_scale=2", "agent.duration_scale=1.5"])
    assert device_wins.agent["ferrovibe"].duration_scale == 2.0 and device_wins.agent["fingertac"].duration_scale == 1.5
    for bad, message in (("agent.ferovibe.duration_scale=2", "agent.DEVICE.FIELD"), ("agent.speed=2", "no field"),
                         ("agent.duration_scale=0", "> 0"), ("agent.duration_scale=fast", "number"),
                         ("agent.endpoint_noise=-1", ">= 0"), ("estimation.c=1", "no field"), ("nothing", "KEY=VALUE"),
                         ("agent.duration_scale=nan", "finite")):
        with pytest.raises(ValueError, match=message):
            parse_settings([bad])
    with pytest.raises(ValueError, match="twice"):
        parse_settings(["estimation.b=1", "estimation.b=2"])


def test_a_device_slowdown_lengthens_that_devices_positioning_trials():
    from devices.profiles import profile_by_model
    from server.simulate.agent import PositioningAgent
    from server.simulate.virtual_device import VirtualDevice
    from server.simulate.virtual_hub import VirtualHub

    def completion_s(settings):
        device = VirtualDevice("fingertac", profile_by_model("fingertac"))
        hub = VirtualHub({"fingertac": device})
        events = []
        hub.listeners.append(lambda r: events.extend(r.view["events"]) if type(r) is State else None)
        hub.switch_scenario("positioning", {"cue": "P1"})
        hub.set_trial("main", {"object": "cube_a", "cue": "P1"}, 0)
        PositioningAgent(hub, device.feel, parse_settings(settings).agent["fingertac"]).run_trial("cube_a", "P1")
        return next(e for e in events if e["name"] == "trial_done")["completion_s"]

    base = completion_s([])
    assert completion_s(["agent.fingertac.duration_scale=1.5"]) > base * 1.2
    assert completion_s(["agent.ferrovibe.duration_scale=1.5"]) == base, "another device's setting changes nothing"


@pytest.fixture(scope="module")
def thesis_stats(tmp_path_factory):
    db = tmp_path_factory.mktemp("pvalues") / "viestac.sqlite"
    build(db, Truth())
    return compute(load(db))[0]


def test_p_values_name_every_test_of_the_analysis(thesis_stats):
    s = thesis_stats
    p = p_values(s)
    assert p["task1.rm_anova"] == s["task1"]["rm_anova"]["p_gg"]
    assert p["task1.quadratic_trend"] == s["task1"]["quadratic_trend"]["p_quadratic"]
    assert p["task2.kendall_tau"] == s["task2"]["kendall_tau_p"]
    assert p["task3.production.b"] == s["task3"]["production"]["fit"]["p_b"]
    posthoc = [k for k in p if k.startswith("task2.pairs.posthoc.")]
    assert len(posthoc) == len(s["task2"]["pairs"]["posthoc"]["tests"]) >= 4
    comparison = next(iter(s["task4"]["comparison"]))
    assert p[f"task4.comparison.{comparison}.completion_time"] == s["task4"]["comparison"][comparison][
        "completion_time"]["p"]
    effects = s["task4"]["fingertac"]["rm_anova"]["completion_time"]["effects"]
    assert all(f"task4.fingertac.rm_anova.completion_time.{e['source']}" in p for e in effects) and len(effects) >= 2
    assert all(v is None or 0.0 <= v <= 1.0 for v in p.values()) and list(p) == sorted(p)


def test_the_cli_refuses_bad_power_input(study_file, tmp_path):
    def cli(*args):
        return subprocess.run([sys.executable, "-m", "server.cli", "study", *args, "--out", str(tmp_path / "x")],
                              capture_output=True, text=True, timeout=60)

    both = cli("--simulate", "--power", "--study", str(study_file))
    assert both.returncode == 2 and "give --simulate" in both.stderr
    for args, message in ((["--participants", "2,x"], "whole numbers"), (["--participants", "0,2"], "at least 1"),
                          (["--set", "agent.speed=2"], "no field"), (["--replications", "0"], "replications"),
                          (["--alpha", "1.5"], "alpha")):
        done = cli("--power", "--study", str(study_file), *args)
        assert done.returncode == 2 and message in done.stderr, (args, done.stderr)
    one = cli("--simulate", "--participants", "2,3", "--study", str(study_file))
    assert one.returncode == 2 and "one number" in one.stderr


def test_a_simulated_study_records_its_effect_settings(study_file, tmp_path):
    from server.simulate.study_run import simulate_study

    def config(out, settings):
        people = parse_settings(settings)
        result = simulate_study(study_file, participants=1, seed=2, out_dir=out, make_participant=people.participant,
                                agent_params=people.agent, settings=people.settings)
        con = sqlite3.connect(result.data_dir / "viestac.sqlite")
        try:
            return json.loads(con.execute("SELECT config_json FROM sessions").fetchone()[0])
        finally:
            con.close()

    assert config(tmp_path / "a", ["estimation.b=0.9"])["settings"] == [["estimation.b", "0.9"]]
    assert "settings" not in config(tmp_path / "b", []), "without settings the config is what it was"
