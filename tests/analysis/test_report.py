"""`kinolab report` on a real small results database written by `kinolab run`, and the HTML
report rendered in headless Chromium."""

import json
import os
import re
import shutil
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SOURCE_DIR = Path(__file__).resolve().parents[2]
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))

EXPERIMENT = """kind: planning
name: report_test
seed: 5
worlds:
  - id: small
    spec:
SPEC
queries:
  random: {count: 6, min_distance: 4, max_distance: 9}
planners:
  - id: eager
    type: eager_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
    params: {heuristic_weight: HW}
  - id: lazy
    type: lazy_mp_astar
    sampler: {type: uniform, params: {samples_per_axis: 3}}
    params: {heuristic_weight: HW}
  - id: tgk
    type: rrtstar_ceres
    params: {refine_iterations: 100}
budget: {time: 5}
store: {trajectories: true, trees: 1}
reproduces: {paper: lazy_mp_astar_paper, rows: {eager: MP-A*, lazy: Lazy, tgk: TGK}}
"""


EXPERIMENT = EXPERIMENT.replace(
    "SPEC\n", textwrap.indent((SOURCE_DIR / "tests/support/small_forest.yaml").read_text(), " " * 6))


def kinolab(*args, cache):
    env = dict(os.environ, KINOLAB_CACHE_DIR=str(cache))
    return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True, env=env,
                          timeout=600)


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Two result sets of the same cases (heuristic weight 2, then 3)."""
    base = tmp_path_factory.mktemp("report")
    out = {}
    for weight in (2, 3):
        path = base / f"hw{weight}.yaml"
        path.write_text(EXPERIMENT.replace("HW", str(weight)))
        directory = base / f"hw{weight}"
        run = kinolab("run", path, "--out", directory, "-j", "2", cache=base / "cache")
        assert run.returncode == 0, run.stderr
        out[weight] = directory
    return out


@pytest.fixture(scope="module")
def report(results):
    directory = results[2] / "report"
    result = kinolab("report", results[2], "--out", directory, "--compare", results[3],
                     cache=results[2].parent / "cache")
    assert result.returncode == 0, result.stderr
    return directory, result.stdout


def test_the_report_directory_holds_html_figures_and_tables(report):
    directory, stdout = report
    html = (directory / "index.html").read_text()
    figures = sorted(p.stem for p in (directory / "figures").glob("*.png"))
    for name in ("ecdf_planning_time", "metrics", "trajectories_small", "search_tree",
                 "progress_anytime_cost"):
        assert name in figures, figures
        assert (directory / "figures" / f"{name}.svg").stat().st_size > 1000
    for name in ("status_counts", "paper_table2", "summary", "paired", "compare"):
        assert (directory / "tables" / f"{name}.md").read_text().startswith("|")
        assert r"\toprule" in (directory / "tables" / f"{name}.tex").read_text()
    # Self-contained: every image is embedded, nothing is fetched.
    assert html.count('src="data:image/png;base64,') == len(figures)
    assert not re.search(r'(src|href)="(https?:)?//', html)
    # It opens with the experiment and provenance, then the counts and the paper's table.
    order = [html.index(s) for s in ("Experiment and provenance", "Runs by status",
                                     "Table II beside kinolab", "Compared with")]
    assert order == sorted(order)
    for key in ("git_commit", "compiler", "ompl_version", "cpu"):
        assert f"<dt>{key}</dt>" in html
    # The terminal summary.
    assert "Table II" in stdout and "MP-A*" in stdout and "Lazy" in stdout


def test_the_report_counts_every_run(report, results):
    directory, _ = report
    counts = (directory / "tables" / "status_counts.md").read_text()
    totals = [int(line.split("|")[-2]) for line in counts.splitlines()[2:]]
    assert sum(totals) == 18  # 6 queries x 3 planners, whatever their status


def test_a_missing_results_directory_is_a_clear_error(tmp_path):
    result = kinolab("report", tmp_path / "nothing", cache=tmp_path / "cache")
    assert result.returncode == 1
    assert "no results database" in result.stderr


def test_the_report_renders_in_headless_chromium(report, tmp_path):
    chromium = shutil.which("chromium")
    assert chromium, "Debian's chromium is missing: bash scripts/setup_debian.sh installs it"
    directory, _ = report
    result = subprocess.run(
        [chromium, "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
         f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=10000",
         "--enable-logging=stderr", "--v=0", "--dump-dom",
         (directory / "index.html").resolve().as_uri()],
        capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    dom = result.stdout
    console = [line for line in result.stderr.splitlines() if "CONSOLE" in line]
    assert not [line for line in console if "Uncaught" in line or "rror" in line], console
    expected = int(re.search(r'data-figures="(\d+)"', dom).group(1))
    loaded = int(re.search(r'data-figures-loaded="(\d+)"', dom).group(1))
    assert expected >= 5 and loaded == expected
    assert dom.count("<table") >= 5
    assert "Table II beside kinolab" in dom
    assert 'class="view3d"' in dom  # the 3D view, inline


def test_the_report_has_a_3d_view_with_the_lazy_tree(report):
    directory, _ = report
    views = sorted(directory.glob("view_*.html"))
    assert views, "no 3D view written"
    text = views[0].read_text()
    scene = json.loads(re.search(r'id="kinolab-scene">(.*?)</script>', text, re.S).group(1))
    assert scene["world"]["boxes"] and len(scene["world"]["boxes"]) % 6 == 0
    trees = [tree for query in scene["queries"] for tree in query["trees"]]
    assert any(tree["edges"]["partial"] for tree in trees)  # the lazy search's tree
    assert len(scene["queries"][0]["trajectories"]) == 3  # every planner's trajectory
    assert "THREE.OrbitControls" in text


def test_an_experiment_that_reproduces_no_paper_gets_no_paper_tables(tmp_path):
    """Reports work for any planners: the paper's tables appear only when the experiment
    says what it reproduces, not because a plugin key matches."""
    path = tmp_path / "plain.yaml"
    text = EXPERIMENT.replace("HW", "2").split("reproduces:")[0]
    path.write_text(text.replace("name: report_test", "name: plain"))
    run = kinolab("run", path, "--out", tmp_path / "plain", "-j", "2", cache=tmp_path / "cache")
    assert run.returncode == 0, run.stderr
    result = kinolab("report", tmp_path / "plain", cache=tmp_path / "cache")
    assert result.returncode == 0, result.stderr
    html = (tmp_path / "plain" / "report" / "index.html").read_text()
    assert "Table II" not in html and "Table I" not in html and "1.76x" not in html
    assert not (tmp_path / "plain" / "report" / "tables" / "paper_table2.md").exists()
    assert "Table II" not in result.stdout and "per planner" in result.stdout
    # The lazy planner's tree is still drawn (chosen by its partial edges, not its key).
    assert (tmp_path / "plain" / "report" / "figures" / "search_tree.png").is_file()


def test_a_version_1_database_loads_with_one_success_definition(results, tmp_path):
    """Databases written before the schema was declared (no schema_version, no success
    column, `timeout` for a killed worker) load, upgraded in memory."""
    sys.path.insert(0, str(SOURCE_DIR / "analysis"))
    from kinolab_analysis.data import load

    old = tmp_path / "old.sqlite"
    shutil.copy(results[2] / "results.sqlite", old)
    with sqlite3.connect(old) as db:
        db.execute("DELETE FROM meta WHERE key = 'schema_version'")
        db.execute("DROP TABLE metrics")
        db.execute("ALTER TABLE runs DROP COLUMN success")
        db.execute("UPDATE runs SET status = 'timeout', message = 'killed after 6 s: ...' "
                   "WHERE planner = 'tgk' AND query = 0")
    loaded = load(old).runs.set_index("run_hash")
    stored = load(results[2]).runs.set_index("run_hash")
    killed = (loaded["planner"] == "tgk") & (loaded["query"] == 0)
    assert set(loaded.loc[killed, "status"]) == {"killed"}
    assert not loaded.loc[killed, "success"].any()
    # Everywhere else the derived success equals the one the runner stored.
    assert loaded.loc[~killed, "success"].equals(stored.loc[loaded.index[~killed], "success"])


def test_runs_load_in_the_experiments_order_whatever_order_workers_finished_in(results,
                                                                             tmp_path):
    """The runs table holds runs in the order parallel workers finished them; loaded, they are
    in the experiment's order (queries, then planners as the file lists them), so tables and
    figures list planners as the file does, the same from any run of the experiment. A config
    that is not YAML leaves the order by name, not an error."""
    sys.path.insert(0, str(SOURCE_DIR / "analysis"))
    from kinolab_analysis.data import load

    stored = load(results[2]).runs
    assert list(dict.fromkeys(stored["planner"])) == ["eager", "lazy", "tgk"]
    assert stored["query"].is_monotonic_increasing
    shuffled = tmp_path / "shuffled.sqlite"
    shutil.copy(results[2] / "results.sqlite", shuffled)
    with sqlite3.connect(shuffled) as db:
        db.execute("CREATE TABLE runs_copy AS SELECT * FROM runs ORDER BY planner DESC, "
                   "query DESC")
        db.execute("DELETE FROM runs")
        db.execute("INSERT INTO runs SELECT * FROM runs_copy")
        db.execute("DROP TABLE runs_copy")
        assert db.execute("SELECT planner FROM runs LIMIT 1").fetchone()[0] == "tgk"
    loaded = load(shuffled).runs
    assert loaded["run_hash"].tolist() == stored["run_hash"].tolist()
    # A configuration that is not YAML is a damaged database: refused, naming table and key.
    with sqlite3.connect(shuffled) as db:
        db.execute("UPDATE meta SET value = ': [not yaml' WHERE key = 'config'")
    with pytest.raises(ValueError, match="table meta, key 'config'"):
        load(shuffled)


def test_the_lazy_regime_and_table_one_readings_beside_a_reproduction(results, tmp_path):
    """A reproduction's directory with lazy-regime experiments and a sampling study with
    readings beside it: the report has the speedup table and one figure per sweep, the
    readings' figure and the verdict, the worlds table and the timing protocol."""
    directory = tmp_path / "quick"
    directory.mkdir()
    shutil.copy(results[2] / "results.sqlite", directory / "results.sqlite")
    sweep = EXPERIMENT.replace("HW", "1").split("reproduces:")[0].replace(
        "name: report_test", "name: regime_test").replace("count: 6", "count: 3")
    sweep += ("sweep:\n  zip:\n    planners.eager.params.edge_samples: [2, 20]\n"
              "    planners.lazy.params.edge_samples: [2, 20]\n")
    (tmp_path / "regime.yaml").write_text(sweep)
    run = kinolab("run", tmp_path / "regime.yaml", "--out", directory / "lazy_regime" / "k",
                  "-j", "2", cache=tmp_path / "cache")
    assert run.returncode == 0, run.stderr
    study = (SOURCE_DIR / "experiments" / "paper_table1_samplers.yaml").read_text()
    study = re.sub(r"moving: \d+", "moving: 3", study)
    study = re.sub(r"samples_per_axis: \[3, 5, 7\]", "samples_per_axis: [3]", study)
    (tmp_path / "study.yaml").write_text(study)
    studied = kinolab("sampling-study", tmp_path / "study.yaml", "--out",
                      directory / "sampling_study" / "t1", cache=tmp_path / "cache")
    assert studied.returncode == 0, studied.stderr
    report = kinolab("report", directory, cache=tmp_path / "cache")
    assert report.returncode == 0, report.stderr
    out = directory / "report"
    figures = {p.stem for p in (out / "figures").glob("*.png")}
    assert {"lazy_speedup_regime_test", "sampling_readings"} <= figures, figures
    regime = (out / "tables" / "lazy_regime.md").read_text()
    assert "edge_samples=2" in regime and "edge_samples=20" in regime
    html = (out / "index.html").read_text()
    assert "Where lazy pays off" in html and "Table I under every reading" in html
    # The reproduced paper's speedup, from papers.yaml, beside the regime's.
    assert "the paper&#39;s figure is 1.76x" in html and "dotted: the paper&#39;s 1.76x" in html
    assert "the paper&#39;s ranking random &lt; uniform &lt; normal holds for alpha in" in html
    assert "Warm: in each run&#39;s worker, 1 discarded plan(s)" in html
    assert (out / "tables" / "worlds.md").read_text().count("| small |") == 1


FAMILIES = """kind: planning
name: families
seed: 3
worlds:
  - id: small
    spec:
SPEC
queries:
  random: {count: 3, min_distance: 4, max_distance: 9}
planners:
  - {id: lazy, type: lazy_mp_astar}
  - {id: hybrid, type: hybrid_astar}
  - {id: bit, type: ompl_geometric, params: {time_limit: LIMIT}}
budget: {time: 3}
timing: {warmup: 0, repeats: 1}
store: {trajectories: true}
sweep:
  grid:
    worlds.small.spec.generators.0.density: [0.05, 0.15]
""".replace("SPEC\n", textwrap.indent(
    (SOURCE_DIR / "tests/support/small_forest.yaml").read_text(), " " * 6))


@pytest.fixture(scope="module")
def families(tmp_path_factory):
    """Three planners of three families (three objectives) on a sweep over the world's
    density, one planner with its own time limit: the results directory and its report."""
    base = tmp_path_factory.mktemp("families")
    (base / "families.yaml").write_text(FAMILIES.replace("LIMIT", "1"))
    run = kinolab("run", base / "families.yaml", "--out", base / "out", "-j", "2",
                  cache=base / "cache")
    assert run.returncode == 0, run.stderr
    report = kinolab("report", base / "out", cache=base / "cache")
    assert report.returncode == 0, report.stderr
    return base, base / "out" / "report"


def test_a_study_of_planner_families_reports_what_a_reviewer_accepts(families):
    base, report = families
    html = (report / "index.html").read_text()
    # Each world variant of the sweep is its own world, in tables, figures and 3D views, and
    # no two sections share a heading.
    worlds = (report / "tables" / "worlds.md").read_text()
    assert worlds.count("| small (density=0.05) |") == 1, worlds
    assert worlds.count("| small (density=0.15) |") == 1, worlds
    headings = re.findall(r"<h[23]>(.*?)</h[23]>", html)
    assert len(headings) == len(set(headings)), sorted(headings)
    assert {"Trajectories in small (density=0.05)", "Trajectories in small (density=0.15)",
            "small (density=0.05) in 3D"} <= set(headings)
    # The budget each planner ran under, its own where its entry set one.
    summary = (report / "tables" / "summary.md").read_text()
    assert "| bit | 1 s (own time_limit) | 6 |" in summary, summary
    assert "| lazy | 3 s | 6 |" in summary, summary
    # Success is exact; approximate answers, timeouts and failures have their own columns.
    assert "| runs | success | approximate | timeout | failed |" in summary, summary
    # Cost is each planner's own objective: three objectives here, so no test of cost.
    with sqlite3.connect(base / "out" / "results.sqlite") as db:
        objectives = dict(db.execute("SELECT planner, objective FROM runs"))
    assert len(set(objectives.values())) == 3, objectives
    paired = (report / "tables" / "paired.md").read_text()
    assert "cost" not in paired and "acceleration_integral" in paired, paired
    assert "cost (own objective)" in summary
    # The motion primitives' jerk is undefined, never 0, and the note says why.
    assert re.search(r"\| lazy \|[^\n]*\| undefined \|", summary), summary
    assert "jerk_integral is undefined for 6 of 6 successful runs of lazy, not 0" in html


def test_runs_of_an_earlier_configuration_are_counted_not_pooled(families, tmp_path):
    """bit's time limit changed, then --resume into the same directory: its earlier runs
    stay in the file, counted apart, never pooled with the new ones."""
    base, _ = families
    shutil.copytree(base / "out", tmp_path / "out", ignore=shutil.ignore_patterns("report"))
    (tmp_path / "families.yaml").write_text(FAMILIES.replace("LIMIT", "0.5"))
    run = kinolab("run", tmp_path / "families.yaml", "--out", tmp_path / "out", "--resume",
                  "-j", "2", cache=base / "cache")
    assert run.returncode == 0, run.stderr
    report = kinolab("report", tmp_path / "out", cache=base / "cache")
    assert report.returncode == 0, report.stderr
    assert "6 stored runs are of an earlier configuration of this experiment" in report.stdout
    tables = tmp_path / "out" / "report" / "tables"
    assert "| bit | 6 | 6 |" in (tables / "stale.md").read_text()
    assert "| bit | 0.5 s (own time_limit) | 6 |" in (tables / "summary.md").read_text()
    assert sum(int(line.split("|")[-2]) for line in
               (tables / "status_counts.md").read_text().splitlines()[2:]) == 18


def test_a_version_7_database_keeps_cost_within_a_planner_type(families, tmp_path):
    """Before schema 8 (no objective, no comparability, no planned table): cost is each
    planner type's own objective, every other result metric compares, every run is current."""
    import pandas as pd
    from kinolab_analysis import data, tables

    base, _ = families
    old = tmp_path / "old.sqlite"
    shutil.copy(base / "out" / "results.sqlite", old)
    with sqlite3.connect(old) as db:
        db.execute("UPDATE meta SET value = '7' WHERE key = 'schema_version'")
        db.execute("DROP TABLE planned")
        for column in ("objective", "time_limit", "time_limit_own", "undefined"):
            db.execute(f"ALTER TABLE runs DROP COLUMN {column}")
        for column in ("direction", "comparable"):
            db.execute(f"ALTER TABLE metrics DROP COLUMN {column}")
        # Version 7 stored a piecewise-constant acceleration's jerk integral as 0.
        db.execute("UPDATE runs SET jerk_integral = 0 WHERE planner = 'lazy'")
    results = data.load(old)
    lazy = results.runs[results.runs["planner"] == "lazy"]
    assert lazy["jerk_integral"].isna().all()
    assert lazy["undefined"].str.contains("jerk_integral: stored as 0 before schema").all()
    assert len(results.runs) == 18 and results.stale.empty
    assert (results.runs["objective"] == results.runs["planner_type"]).all()
    assert tables.comparable(results.metrics, ("cost", "duration", "expansions")) == (
        "cost", "duration")
    # lazy2, a copy of lazy: the one pair of one planner type, so the one cost test.
    runs = results.runs
    twin = pd.concat([runs, runs[runs["planner"] == "lazy"].assign(planner="lazy2")])
    paired = tables.paired(twin, tables.comparable(results.metrics, tables.PAIRED))
    tested = paired[paired["metric"] == tables.OWN_COST]
    assert list(zip(tested["a"], tested["b"])) == [("lazy", "lazy2")]
    assert tables.budgets(results.runs)["bit"] == ""
