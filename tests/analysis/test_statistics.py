"""The analysis package's statistics on synthetic data with known answers (by hand, or by
scipy called directly)."""

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from kinolab_analysis import paper, plots, stats, tables


def test_wilson_interval_matches_the_textbook_values():
    # 8 of 10: the Wilson 95 % interval is [0.4902, 0.9433] (Newcombe 1998, table I).
    interval = stats.wilson(8, 10)
    assert interval.estimate == 0.8
    assert interval.low == pytest.approx(0.4902, abs=1e-4)
    assert interval.high == pytest.approx(0.9433, abs=1e-4)
    # All successes: the upper bound is 1, the lower one n / (n + z^2).
    all_ok = stats.wilson(20, 20)
    assert all_ok.high == 1.0
    assert all_ok.low == pytest.approx(20 / (20 + stats.Z95 ** 2), abs=1e-12)
    assert math.isnan(stats.wilson(0, 0).estimate)


def test_holm_adjustment_by_hand():
    # Sorted 0.01, 0.03, 0.04 times 3, 2, 1 -> 0.03, 0.06, 0.04 -> monotone 0.03, 0.06, 0.06.
    assert stats.holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    adjusted = stats.holm([0.5, math.nan, 0.01])
    assert adjusted[0] == pytest.approx(0.5) and adjusted[2] == pytest.approx(0.02)
    assert math.isnan(adjusted[1])


def test_mcnemar_exact_by_hand():
    a = [True] * 5 + [True] + [False] * 9 + [False] * 5
    b = [True] * 5 + [False] + [True] * 9 + [False] * 5
    a_only, b_only, p = stats.mcnemar(a, b)
    assert (a_only, b_only) == (1, 9)
    assert p == pytest.approx(2 * (1 + 10) / 1024)  # 2 P(X <= 1), X ~ Binomial(10, 1/2)
    assert stats.mcnemar([True, False], [True, False])[2] == 1.0


def test_wilcoxon_agrees_with_scipy_and_the_effect_size_by_hand():
    rng = np.random.default_rng(1)
    a = rng.normal(10, 2, 40)
    b = a - rng.normal(0.8, 1, 40)
    test = stats.wilcoxon(a, b)
    assert test.p == pytest.approx(sps.wilcoxon(a - b).pvalue)
    assert test.n == 40
    d = a - b
    ranks = sps.rankdata(np.abs(d))
    expected = (ranks[d > 0].sum() - ranks[d < 0].sum()) / ranks.sum()
    assert test.rank_biserial == pytest.approx(expected)
    assert stats.wilcoxon([2, 3, 4], [1, 1, 1]).rank_biserial == 1.0  # a always larger
    # Pairs with a missing value are dropped.
    assert stats.wilcoxon([1, math.nan, 3], [0, 1, 2]).n == 2


def test_vargha_delaney_a_by_hand():
    assert stats.vargha_delaney_a([1, 2, 3], [1, 2, 3]) == 0.5
    assert stats.vargha_delaney_a([4, 5], [1, 2]) == 1.0
    assert stats.vargha_delaney_a([1, 2], [4, 5]) == 0.0
    assert stats.vargha_delaney_a([1, 3], [2]) == 0.5


def test_bootstrap_interval_is_seeded_and_covers_the_median():
    rng = np.random.default_rng(3)
    values = rng.exponential(2.0, 400)
    first = stats.bootstrap(values, np.median, seed=7)
    assert first == stats.bootstrap(values, np.median, seed=7)
    assert first.estimate == pytest.approx(np.median(values))
    assert first.low < first.estimate < first.high
    assert first.low < 2.0 * math.log(2) < first.high  # the true median
    constant = stats.bootstrap([5.0] * 10)
    assert (constant.low, constant.high) == (5.0, 5.0)
    assert math.isnan(stats.bootstrap([math.nan]).estimate)


def test_time_to_solve_ecdf_counts_failures_as_unsolved():
    x, y = stats.ecdf_unsolved([1.0, 2.0, 3.0, 4.0], [True, False, True, True])
    assert x.tolist() == [1.0, 3.0, 4.0]
    assert y.tolist() == [0.25, 0.5, 0.75]


def synthetic_runs(n=30, seed=0):
    """Planner 'fast' takes 1 ms less than 'slow' on every case; 'flaky' fails a third."""
    rng = np.random.default_rng(seed)
    rows = []
    for query in range(n):
        base = rng.uniform(5, 10)
        for planner, offset, success in (("slow", 0.0, True), ("fast", -1.0, True),
                                         ("flaky", 0.5, query % 3 != 0)):
            rows.append({"run_hash": f"{planner}{query}", "planner": planner,
                         "planner_type": {"slow": "eager_mp_astar", "fast": "lazy_mp_astar",
                                          "flaky": "rrtstar_ceres"}[planner],
                         "sweep": "", "world": "w", "query": query, "repetition": 0,
                         "status": "exact" if success else "crash",
                         "checker_valid": 1 if success else 0,
                         "planning_time_ms": base + offset if success else math.nan,
                         "expansions": 100.0, "distance_to_goal": 0.1, "cost": base})
    runs = pd.DataFrame(rows)
    runs["success"] = stats.is_success(runs)
    runs["paper"] = runs["planner_type"].map({"rrtstar_ceres": "TGK", "eager_mp_astar": "MP-A*",
                                              "lazy_mp_astar": "Lazy"})
    return runs


def test_summary_and_status_counts_never_drop_failures():
    runs = synthetic_runs()
    counts = tables.status_counts(runs)
    assert counts.loc["flaky", "crash"] == 10 and counts.loc["flaky", "total"] == 30
    summary = tables.summary(runs).set_index("planner")
    assert summary.loc["flaky", "runs"] == 30 and summary.loc["flaky", "failed"] == 10
    assert summary.loc["flaky", "success"].estimate == pytest.approx(20 / 30)
    slow = runs[runs["planner"] == "slow"]["planning_time_ms"]
    assert summary.loc["slow", "median planning_time_ms"].estimate == pytest.approx(slow.median())


def test_failure_reasons_group_messages_per_planner_and_status():
    runs = pd.DataFrame([
        {"planner": "tgk", "status": "invalid_start", "success": False, "checker_valid": 0,
         "message": f"start (1, {y}, 1.5) is in collision: its distance 0.3{y} m is below 0.35"}
        for y in range(4)] + [
        {"planner": "tgk", "status": "timeout", "success": False, "checker_valid": 0,
         "message": "budget spent"},
        {"planner": "lazy", "status": "exact", "success": False, "checker_valid": 0,
         "message": "", "checker_detail": "position (1, 2, 3) leaves the map"},
        {"planner": "lazy", "status": "exact", "success": True, "checker_valid": 1,
         "message": ""}])
    table = tables.failure_reasons(runs)
    assert list(table["planner"]) == ["lazy", "tgk", "tgk"]
    tgk = table[table["planner"] == "tgk"].set_index("status")
    assert tgk.loc["invalid_start", "runs"] == 4  # one reason, four points
    assert tgk.loc["invalid_start", "example"].startswith("start (1, 0, 1.5)")
    assert tgk.loc["timeout", "runs"] == 1
    lazy = table[table["planner"] == "lazy"].iloc[0]
    assert lazy["example"] == "refused by the checker: position (1, 2, 3) leaves the map"
    assert tables.failure_reasons(runs[runs["success"]]).empty


def test_paired_comparisons_find_the_constant_difference():
    table = tables.paired(synthetic_runs())
    row = table[(table["a"] == "slow") & (table["b"] == "fast") &
                (table["metric"] == "planning_time_ms")].iloc[0]
    assert row["n"] == 30
    assert row["effect size"] == 1.0  # slow is larger on every case
    assert row["p"] == pytest.approx(sps.wilcoxon(np.ones(30)).pvalue)
    success = table[(table["a"] == "slow") & (table["b"] == "flaky") &
                    (table["test"] == "McNemar")].iloc[0]
    assert success["p"] == pytest.approx(2 * 0.5 ** 10)  # 10 discordant pairs, all one way
    assert (table["p (Holm)"] >= table["p"] - 1e-15).all()


def test_paper_table_two_beside_the_measured_medians():
    import dataclasses
    # Declared in the setting (the one variant, ""), with no cap to check: the p are tested.
    figures = dataclasses.replace(paper.load("lazy_mp_astar_paper"), max_expansions=math.nan)
    table = paper.table2(synthetic_runs(), figures, {""}).set_index("planner")
    assert table.loc["MP-A*", "paper T (ms)"] == 6.82
    assert table.loc["Lazy", "kinolab N"].estimate == 100.0
    measured = synthetic_runs().query("planner == 'fast'")["planning_time_ms"]
    assert table.loc["Lazy", "p T (ms)"] == pytest.approx(
        sps.wilcoxon(measured - 3.87).pvalue)


def test_tables_as_markdown_and_booktabs_latex():
    table = pd.DataFrame({"planner": ["a_b"], "T": [stats.Interval(1.0, 0.5, 2.0)],
                          "p": [math.nan]})
    markdown = tables.to_markdown(table)
    assert markdown.splitlines()[0] == "| planner | T | p |"
    assert "| a_b | 1 [0.5, 2] | - |" in markdown
    latex = tables.to_latex(table, "caption")
    for command in (r"\toprule", r"\midrule", r"\bottomrule", r"a\_b"):
        assert command in latex


def test_paper_table_one_from_a_sampling_study_summary(tmp_path):
    csv = tmp_path / "summary.csv"
    csv.write_text("sampler,type,controls,alpha,mean_nearest,paper_alpha,paper_mean_nearest\n"
                   "uniform,uniform,125,0.9,0.07,0.84,0.069\n"
                   "mine,uniform,125,0.5,0.02,,\n")
    table = paper.table1(csv, paper.load("lazy_mp_astar_paper")).set_index("sampler")
    assert table.loc["uniform", "kinolab alpha"] == 0.9
    assert table.loc["uniform", "paper L (m)"] == 0.069
    assert table.loc["mine", "kinolab L (m)"] == 0.02
    assert math.isnan(table.loc["mine", "paper alpha"])
    assert math.isnan(table.loc["uniform", "p alpha"])  # no per-state file beside it
    (tmp_path / "sampling_study.csv").write_text(
        "sampler,state,alpha,mean_nearest\n" +
        "".join(f"uniform,{i},{0.9 + 0.01 * i},0.07\n" for i in range(8)))
    table = paper.table1(csv, paper.load("lazy_mp_astar_paper")).set_index("sampler")
    alphas = [0.9 + 0.01 * i for i in range(8)]
    assert table.loc["uniform", "p alpha"] == pytest.approx(
        sps.wilcoxon(np.array(alphas) - 0.84).pvalue)


def test_compare_two_result_sets_case_by_case():
    before = synthetic_runs()
    after = before.copy()
    after["planning_time_ms"] = after["planning_time_ms"] * 0.5  # twice as fast
    table = tables.compare(after, before)
    slow = table[table["planner"] == "slow"]
    success = slow[slow["test"] == "McNemar"].iloc[0]
    assert success["cases"] == 30 and success["p"] == 1.0
    time_row = slow[slow["metric"] == "planning_time_ms"].iloc[0]
    assert time_row["effect size"] == -1.0  # A (after) smaller on every case
    assert time_row["T A (ms)"].estimate == pytest.approx(time_row["T B (ms)"].estimate / 2)
    assert time_row["p"] == pytest.approx(sps.wilcoxon(np.ones(30)).pvalue)
    assert (table["p (Holm)"] >= table["p"] - 1e-15).all()


def test_sweep_labels_become_axes():
    assert tables.sweep_axes("planners.eager.params.edge_samples=5, "
                             "planners.lazy.params.edge_samples=5") == {"edge_samples": "5"}
    assert tables.sweep_axes("worlds.f.spec.generators.0.density=0.1, planners.eager.params."
                             "edge_samples=2, planners.lazy.params.edge_samples=2") == {
        "density": "0.1", "edge_samples": "2"}
    # The same component with different values keeps its whole path.
    assert tables.sweep_axes("planners.a.params.tau=0.4, planners.b.params.tau=0.6") == {
        "planners.a.params.tau": "0.4", "planners.b.params.tau": "0.6"}
    assert tables.sweep_axes("full") == {}


def test_lazy_speedup_per_sweep_value_with_equal_cost():
    """Eager takes k times lazy's time at sweep value k; one case of value 3 has a different
    cost (and a wild time), and one of value 2 is unsolved by lazy (not counted)."""
    rows = []
    for k in (2, 3):
        label = f"planners.eager.params.edge_samples={k}, planners.lazy.params.edge_samples={k}"
        for query in range(10):
            for planner, kind, time in (("eager", "eager_mp_astar", k * (query + 1.0)),
                                        ("lazy", "lazy_mp_astar", query + 1.0)):
                solved = not (k == 2 and planner == "lazy" and query == 0)
                cost = 10.0 + query + (0.5 if (k, query, planner) == (3, 4, "lazy") else 0.0)
                rows.append({"run_hash": f"{planner}{k}{query}", "planner": planner,
                             "planner_type": kind, "sweep": label, "world": "w",
                             "query": query, "repetition": 0,
                             "status": "exact" if solved else "no_solution",
                             "checker_valid": 1 if solved else 0, "success": solved,
                             "planning_time_ms": time if (k, query) != (3, 4) else 1e3,
                             "cost": cost})
    table = tables.lazy_speedup(pd.DataFrame(rows)).set_index("edge_samples")
    # Value 2: 9 cases both solved; value 3: the case of unequal cost (and a wild time) is
    # left out of the ratio, counted in the share.
    assert table.loc["2", "cases"] == 9 and table.loc["3", "cases"] == 9
    assert table.loc["2", "speedup"].estimate == pytest.approx(2.0)
    assert table.loc["3", "speedup"].estimate == pytest.approx(3.0)
    assert table.loc["3", "max speedup"] == pytest.approx(3.0)
    assert table.loc["2", "equal cost"] == 1.0 and table.loc["3", "equal cost"] == 0.9
    # Without one eager and one lazy planner there is nothing to compare.
    assert tables.lazy_speedup(pd.DataFrame(rows).query("planner == 'eager'")).empty


def test_sweep_winners_compare_on_the_cases_every_planner_solved():
    """At K = 2 "a" is twice as fast as "b" and "c" ten times slower; at K = 80 "c" is fastest
    but fails one case, which is left out for every planner."""
    rows = []
    for k in (2, 80):
        label = ", ".join(f"planners.{p}.params.edge_samples={k}" for p in "abc")
        for query in range(12):
            base = query + 1.0
            times = ({"a": base, "b": 2 * base, "c": 10 * base} if k == 2 else
                     {"a": base + (0.01 if query % 2 else -0.01), "b": base, "c": base / 4})
            for planner, time in times.items():
                solved = not (k == 80 and planner == "c" and query == 0)
                rows.append({"planner": planner, "sweep": label, "world": "w", "query": query,
                             "repetition": 0, "success": solved,
                             "planning_time_ms": time if solved else math.nan})
    table = tables.sweep_winners(pd.DataFrame(rows)).set_index("edge_samples")
    assert list(table.index) == ["2", "80"]
    low, high = table.loc["2"], table.loc["80"]
    assert (low["winner"], low["runner-up"], low["cases"], low["of"]) == ("a", "b", 12, 12)
    assert low["ratio"] == pytest.approx(2.0)
    assert low["p (Holm)"] < 0.05
    assert (high["winner"], high["cases"], high["of"]) == ("c", 11, 12)
    # Medians over queries 1..11 (the case c failed is out): c's is (6 + 1) / 4.
    assert high["winner median"] == pytest.approx(1.75)
    assert high["ratio"] == pytest.approx(4.0, rel=0.01)
    figure = plots.sweep_winners(table.reset_index())
    assert figure is not None and len(figure.axes[0].patches) == 2
    # One sweep value or one planner: nothing to draw or compare.
    assert plots.sweep_winners(table.reset_index().head(1)) is None
    assert "winner" not in tables.sweep_winners(pd.DataFrame(rows).query("planner == 'a'"))


def test_table_one_readings_verdict_counts_the_readings_that_rank_as_the_paper():
    rows = []
    for threshold in (0.05, 0.1):
        for sampler, alpha, length in (("random", 0.6, 0.049), ("uniform", 0.84, 0.069),
                                       ("normal", 0.94, 0.079)):
            # At 0.1 the paper's figures exactly; at 0.05 the ranking of alpha reversed.
            a = alpha if threshold == 0.1 else 1.0 - alpha
            rows.append({"sampler": sampler, "controls": 125, "distance": "position",
                         "propagation": "exact", "pooling": "per_state",
                         "threshold": threshold, "alpha": a, "mean_nearest": length})
    table, verdict = paper.sampling_readings(pd.DataFrame(rows), paper.load("lazy_mp_astar_paper"))
    assert len(table) == 2
    assert table["alpha ranked as the paper"].tolist() == [False, True]
    assert table["L ranked as the paper"].all()
    assert table["largest gap to the paper"].min() == pytest.approx(0.0)
    assert "holds for alpha in 1, for L in 2 and for both in 1" in verdict
    assert "threshold 0.1" in verdict


def test_worlds_timing_and_table_two_per_variant_over_answered_runs():
    rows = []
    for variant in ("full", "horizon"):
        for query in range(4):
            for planner, kind in (("eager", "eager_mp_astar"), ("lazy", "lazy_mp_astar")):
                horizon = variant == "horizon"
                rows.append({
                    "run_hash": f"{variant}{planner}{query}", "planner": planner,
                    "planner_type": kind, "sweep": variant, "world": "w", "query": query,
                    "repetition": 0, "status": "approximate" if horizon else "exact",
                    "checker_valid": 1, "line_blocked": 1.0 if query < 3 else 0.0,
                    "start_x": 0.0, "start_y": 0.0, "start_z": 1.0, "goal_x": 10.0,
                    "goal_y": 0.0, "goal_z": 1.0,
                    "planning_time_ms": 2.0 if planner == "lazy" else 4.0,
                    "planning_time_min_ms": 1.5, "planning_time_cold_ms": 6.0,
                    "expansions": 1000.0, "distance_to_goal": 2.0 if horizon else 0.1,
                    "cost": 5.0})
    runs = pd.DataFrame(rows)
    runs["success"] = stats.is_success(runs)
    runs["paper"] = runs["planner_type"].map({"eager_mp_astar": "MP-A*", "lazy_mp_astar": "Lazy"})
    worlds = tables.worlds(runs).set_index("world")
    assert worlds.loc["w", "queries"] == 4
    assert worlds.loc["w", "straight line blocked"].estimate == pytest.approx(0.75)
    assert worlds.loc["w", "query length (m)"].estimate == pytest.approx(10.0)
    timing = tables.timing(runs).set_index("planner")
    assert timing.loc["lazy", "cold / warm"].estimate == pytest.approx(3.0)
    assert timing.loc["eager", "fastest T (ms)"].estimate == pytest.approx(1.5)
    table2 = paper.table2(runs, paper.load("lazy_mp_astar_paper")).set_index(["variant", "planner"])
    # Budget stops are not successes but answered runs: T, N and D come from them.
    assert table2.loc[("horizon", "Lazy"), "success"].estimate == 0.0
    assert table2.loc[("horizon", "Lazy"), "answered"].estimate == 1.0
    assert table2.loc[("horizon", "Lazy"), "kinolab T (ms)"].estimate == pytest.approx(2.0)
    assert table2.loc[("horizon", "MP-A*"), "kinolab D (m)"].estimate == pytest.approx(2.0)
    assert table2.loc[("full", "MP-A*"), "kinolab D (m)"].estimate == pytest.approx(0.1)


def test_wilson_interval_always_holds_its_estimate():
    # At 0 or n successes rounding once put a bound a hair past the estimate, and a plot's
    # error bar went negative.
    for n in range(1, 300):
        for k in (0, 1, n - 1, n):
            interval = stats.wilson(k, n)
            assert interval.low <= interval.estimate <= interval.high, (k, n)


def test_progress_step_values_keep_every_run_and_hold_the_last_value():
    samples = pd.DataFrame({"run_hash": ["a", "a", "a", "b", "b"],
                            "time_ms": [2.0, 5.0, 9.0, 1.0, 3.0],
                            "value": [30.0, 25.0, 20.0, 12.0, 11.0]})
    table = stats.step_values(samples, ["a", "b", "c"], [0.5, 1.0, 2.0, 4.0, 10.0])
    assert table[0].tolist() == [math.inf, math.inf, 30.0, 30.0, 20.0]
    assert table[1].tolist() == [math.inf, 12.0, 12.0, 11.0, 11.0]
    assert np.isinf(table[2]).all()  # never solved
    # The runs that stopped early (b at 3 ms, the cheapest) still count later: the median
    # over all runs never rises, unlike a median over the runs still going.
    medians = np.median(table, axis=0)
    assert all(later <= earlier for earlier, later in zip(medians, medians[1:]))


def test_which_planner_pairs_every_planner_against_the_lazy_one():
    runs = synthetic_runs()
    for metric, value in (("duration", 8.0), ("jerk_integral", 0.0), ("min_clearance", 0.3)):
        runs[metric] = value
    assert tables.reference_planner(runs) == "fast"  # the lazy_mp_astar one
    table = tables.which_planner(runs, "fast").set_index("planner")
    assert list(table.index) == ["slow", "fast", "flaky"] and (table["world"] == "w").all()
    assert table.loc["flaky", "success"].estimate == pytest.approx(20 / 30)
    # 'slow' is 1 ms slower on all 30 cases: Wilcoxon's exact p is 2 / 2^30, Holm at most
    # times the number of tests; the reference has no test against itself.
    assert table.loc["slow", "p planning_time_ms vs fast"] < 1e-6
    assert math.isnan(table.loc["fast", "p planning_time_ms vs fast"])
    # McNemar on success: flaky fails 10 cases the reference solves (exact p = 2 / 2^10),
    # Holm-adjusted over the table's 10 tests.
    raw = 2 * 0.5 ** 10
    assert raw <= table.loc["flaky", "p success vs fast"] <= 10 * raw


def test_load_and_machine_warnings():
    from kinolab_analysis import report
    from kinolab_analysis.data import Results
    runs = pd.DataFrame({"load_average": [0.5, 1.2, 3.4, 9.0]})
    warnings = report.load_warnings(runs, {"cores": "2"})
    assert len(warnings) == 1 and warnings[0].startswith("2 of 4 runs") and "9.0" in warnings[0]
    assert report.load_warnings(runs[runs["load_average"] < 2], {"cores": "2"}) == []
    assert report.load_warnings(pd.DataFrame({"load_average": [math.nan]}), {"cores": "2"}) == []
    assert report.load_warnings(runs, {}) == []  # written before the machine was recorded
    a = Results(paths=[], runs=pd.DataFrame({"load_average": [0.5, 0.7]}),
                meta={"machine": "CPU A, 2 cores"})
    same = Results(paths=[], runs=pd.DataFrame({"load_average": [0.6]}),
                   meta={"machine": "CPU A, 2 cores"})
    loaded = Results(paths=[], runs=pd.DataFrame({"load_average": [9.0]}),
                     meta={"machine": "CPU B, 8 cores"})
    assert report.machine_differences(a, same) == []
    differences = report.machine_differences(a, loaded)
    assert len(differences) == 2
    assert "CPU A, 2 cores against CPU B, 8 cores" in differences[0]
    assert "0.6 against 9.0" in differences[1]


def test_figures_read_as_numbers_not_noise():
    assert stats.number(3.56e-15) == "0" and stats.number(-2e-12) == "0"
    assert stats.number(1246.5) == "1,250" and stats.number(3390.0) == "3,390"
    assert stats.number(1000.0) == "1,000" and stats.number(25317) == "25,317"
    assert stats.number(12.0) == "12" and stats.number(0.337) == "0.337"
    assert stats.number(3.9e-18, noise=0) == "3.9e-18" and stats.number(math.inf) == "-"
    assert tables.text(3.9e-18, column="p T (ms)") == "3.9e-18"
    interval = stats.Interval(3.56e-15, 1.79e-15, 5.02e-15)
    assert interval.format() == "0 [0, 0]"
    assert tables.text(stats.Interval(1.0, 0.963, 1.0), column="success") == "100 % [96.3, 100]"
    assert tables.text(0.25, column="equal cost") == "25 %"
    assert tables.text(np.int64(3390)) == "3,390"
    assert tables.header("p T (ms)") == "p T" and tables.header("kinolab T (ms)") == "kinolab T (ms)"


def test_importing_the_package_leaves_the_backend_alone():
    import subprocess
    import sys
    code = ("import matplotlib; matplotlib.use('svg'); import kinolab_analysis.report, "
            "kinolab_analysis.plots; print(matplotlib.get_backend())")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parents[2] / "analysis")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "svg"


def test_the_papers_table_tests_only_the_declared_and_matching_setting():
    figures = paper.load("lazy_mp_astar_paper")
    rows = []
    for variant, n in (("full", 1250.0), ("horizon", 1000.0), ("capped_wrong", 800.0)):
        for family in ("MP-A*", "Lazy", "TGK"):
            for query in range(8):
                rows.append({"sweep": variant, "world": "w", "paper": family, "query": query,
                             "status": "approximate", "checker_valid": 1, "success": False,
                             "planning_time_ms": 5.0 + query, "distance_to_goal": 2.0,
                             "expansions": math.nan if family == "TGK" else n})
    runs = pd.DataFrame(rows)
    verdicts = paper.in_setting(runs, figures, {"horizon", "capped_wrong"})
    assert verdicts["full"] == "not the paper's setting (not declared)"
    assert verdicts["horizon"] == "the paper's"
    assert "median N is Lazy 800, MP-A* 800, the paper's cap 1,000" in verdicts["capped_wrong"]
    table = paper.table2(runs, figures, {"horizon", "capped_wrong"})
    tested = table[table["p T (ms)"].notna()]
    assert set(tested["variant"]) == {"horizon"} and len(tested) == 3
    assert table[table["variant"] != "horizon"]["p N"].isna().all()


def test_a_count_named_like_a_share_stays_a_count():
    assert tables.text(1.0, column="unsolved") == "1"
    assert tables.text(0.96, column="straight line blocked") == "96 %"
    assert tables.text(0.5, column="line_blocked") == "50 %"


def test_success_over_the_sweep_plots_a_wilson_interval_per_planner_and_value():
    runs = pd.DataFrame({
        "planner": ["lazy"] * 6 + ["tgk"] * 6,
        "sweep": (["v=2"] * 3 + ["v=4"] * 3) * 2,
        "success": [True, True, True, True, False, False, True, False, False, False, False,
                    False],
    })
    figure = plots.sweep_success(runs)
    axis = figure.axes[0]
    # One error-bar line per planner, at the success rates of its two sweep values.
    lines = [line for line in axis.get_lines() if line.get_marker() == "o"]
    rates = sorted(tuple(round(y, 6) for y in line.get_ydata()) for line in lines)
    assert rates == [(round(1 / 3, 6), 0.0), (1.0, round(1 / 3, 6))]
    assert plots.sweep_success(runs[runs["sweep"] == "v=2"]) is None  # no sweep, no figure


def test_a_flight_sweep_is_plotted_over_density_per_planner_and_speed_per_camera():
    # density x camera (grid) x one speed per planner (zip): three dimensions, the zipped
    # keys one.
    labels = [f"flight.sensor.range={r}, worlds.forest.spec.generators.0.density={d}, "
              f"planners.a.params.max_velocity={v}, planners.b.params.max_velocity={v}"
              for r in (10, 5) for d in (0.2, 0.1, 0.05) for v in (2, 4)]
    dimensions, values = plots.sweep_axes(labels)
    assert dimensions == ["range", "density", "max_velocity"]
    assert values.loc[labels[3], "density"] == "0.1"
    rows = []
    for label in labels:
        for planner, successes in (("a", 3), ("b", 1)):
            rows += [{"planner": planner, "sweep": label, "success": k < successes}
                     for k in range(4)]
    figure = plots.success_grid(pd.DataFrame(rows))
    # A panel per camera range, a line per planner and speed, over the three densities.
    assert len(figure.axes) == 2
    lines = [line for line in figure.axes[0].get_lines() if line.get_marker() in "os"]
    assert len(lines) == 4
    assert all(sorted(line.get_xdata()) == [0.05, 0.1, 0.2] for line in lines)
    assert sorted({round(y, 6) for line in lines for y in line.get_ydata()}) == [0.25, 0.75]
    assert figure.axes[0].get_xlabel() == "density"
    assert figure.axes[0].get_title() == "range 10" and figure.axes[1].get_title() == "range 5"
    assert "max_velocity 4" in lines[-1].get_label() or any(
        "max_velocity 4" in text.get_text() for text in figure.axes[-1].get_legend().get_texts())
    one = pd.DataFrame(rows)
    assert plots.success_grid(one[one["sweep"].isin(labels[:2])]) is None  # one dimension


def test_the_flight_timing_protocol_names_the_timing_each_variant_ran_with():
    from kinolab_analysis.report import timing_protocol
    config = "kind: flight\nflight: {replan_budget: 0.1}\n"
    meta = {"schema_version": "6", "config": config + "\n--- # variants\n- (no sweep)\n"}
    assert "real time (a plan measured past its latency" in timing_protocol(meta)
    assert "deterministic" not in timing_protocol(meta)
    meta["config"] = (config.replace("{replan_budget: 0.1}", "{timing: deterministic}")
                      + "\n--- # variants\n- (no sweep)\n")
    assert "deterministic (every plan" in timing_protocol(meta)
    meta["config"] = (config + "\n--- # variants\n- flight.timing=real_time\n"
                      "- flight.timing=deterministic\n")
    both = timing_protocol(meta)
    assert "real time" in both and "deterministic" in both and "reported apart" in both


def test_the_back_end_matrix_crosses_front_ends_with_the_back_ends_the_sweep_chose():
    from kinolab_analysis.report_tables import back_end_matrix
    rows = []
    for back_end, back_ms, ok in (("none", 0.01, 4), ("bspline", 30.0, 3), ("corridor_minco", 5.0, 2)):
        label = (f"planners.lazy.params.back_end={back_end}, "
                 f"planners.bitstar.params.back_end={back_end}")
        for planner in ("lazy", "bitstar"):
            for query in range(4):
                success = query < ok
                rows.append({"sweep": label, "planner": planner, "query": query,
                             "status": "exact" if success else "back_end_failed",
                             "checker_valid": 1 if success else 0, "success": success,
                             "planning_time_ms": (2.0 if planner == "lazy" else 100.0) + back_ms,
                             # `none` is not run: no front and back times of its own
                             "time_front_end_ms": (math.nan if back_end == "none" else
                                                   2.0 if planner == "lazy" else 100.0),
                             "time_back_end_ms": math.nan if back_end == "none" else back_ms,
                             "duration": 5.0 + query,
                             "jerk_integral": 1.0, "min_clearance": 0.3})
    matrix = back_end_matrix(pd.DataFrame(rows)).set_index(["front end", "back end"])
    assert len(matrix) == 6  # two front ends x three back ends, each named by its own value
    assert matrix.loc[("lazy", "corridor_minco"), "success"].estimate == pytest.approx(0.5)
    assert matrix.loc[("bitstar", "bspline"), "median time_back_end_ms"].estimate == 30.0
    assert matrix.loc[("bitstar", "none"), "median time_front_end_ms"].estimate == 100.01
    assert matrix.loc[("bitstar", "none"), "median time_back_end_ms"].estimate == 0.0
    assert matrix.loc[("lazy", "bspline"), "median duration"].estimate == pytest.approx(6.0)
    # Variants that differ in a back end's parameter stay apart.
    order = pd.DataFrame(rows).assign(
        sweep=lambda r: r["sweep"] + ", planners.lazy.params.back_end.order=" +
        r["query"].map(lambda q: "3" if q < 2 else "4"))
    keys = set(back_end_matrix(order)["back end"])
    assert "corridor_minco (order=3)" in keys and "corridor_minco (order=4)" in keys
    # A sweep that does not choose back ends has no matrix.
    assert back_end_matrix(pd.DataFrame(rows).assign(sweep="planners.lazy.params.x=1")) is None
