"""`kinolab report` and `kinolab export` on hostile inputs: every failure is one line,
`kinolab: error: ...`, naming the file and the problem, exit status 1, no Python traceback,
and nothing written; two experiments are pooled only when asked for, then labelled."""

import hashlib
import sqlite3
from contextlib import closing
from pathlib import Path

import pytest

from conftest import tiny_experiment



@pytest.fixture(scope="module")
def two_experiments(tmp_path_factory):
    """Two tiny experiments that differ only in their seed (so in their config hash)."""
    import os
    import subprocess

    from conftest import BINARY

    base = tmp_path_factory.mktemp("hostile_report")
    out = []
    for seed in (5, 6):
        directory = base / f"seed{seed}"
        run = subprocess.run([BINARY, "run", str(tiny_experiment(base, "hostile_report", seed)),
                              "--out", str(directory)],
                             capture_output=True, text=True, timeout=300,
                             env=dict(os.environ, KINOLAB_CACHE_DIR=str(base / "cache")))
        assert run.returncode == 0, run.stderr
        out.append(directory)
    return out


def tree_digest(directory: Path) -> str:
    """Every file under `directory` (names and bytes), to show nothing was written."""
    digest = hashlib.sha256()
    for path in sorted(directory.rglob("*")):
        digest.update(str(path.relative_to(directory)).encode())
        if path.is_file():
            digest.update(path.read_bytes())
    return digest.hexdigest()


def assert_one_line_error(result, *needles):
    assert result.returncode == 1, (result.stdout, result.stderr)
    assert "Traceback" not in result.stderr, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("kinolab: error: "), result.stderr
    for needle in needles:
        assert needle in lines[0], lines[0]


def copy_database(source: Path, target: Path) -> Path:
    target.mkdir()
    with closing(sqlite3.connect(source / "results.sqlite")) as db, \
            closing(sqlite3.connect(target / "results.sqlite")) as copy:
        db.backup(copy)
    return target


def execute(directory: Path, statement: str) -> None:
    with closing(sqlite3.connect(directory / "results.sqlite")) as db:
        db.execute(statement)
        db.commit()


def test_databases_without_runs_are_refused_by_name(kinolab, two_experiments, tmp_path):
    zero = copy_database(two_experiments[0], tmp_path / "zero")
    execute(zero, "DELETE FROM runs")  # as an experiment killed before its first run ended
    no_table = copy_database(two_experiments[0], tmp_path / "no_table")
    execute(no_table, "DROP TABLE runs")
    garbage = tmp_path / "garbage"
    garbage.mkdir()
    (garbage / "results.sqlite").write_bytes(bytes(range(256)) * 12)
    for directory, problem in ((zero, "no run has ended yet"),
                               (no_table, "not a kinolab results database"),
                               (garbage, "not a kinolab results database")):
        before = tree_digest(tmp_path)
        result = kinolab("report", directory, "--out", tmp_path / "report")
        assert_one_line_error(result, str(directory / "results.sqlite"), problem)
        assert tree_digest(tmp_path) == before
        assert not (tmp_path / "report").exists()


def test_a_damaged_meta_or_worlds_table_is_refused_naming_table_and_key(kinolab, two_experiments,
                                                                        tmp_path):
    """Before: Python's ParserError, TypeError or "invalid literal for int()" ("please report
    it"); now one line naming the file, the table and the key."""
    cases = (("UPDATE meta SET value = 'abc' WHERE key = 'schema_version'",
              "table meta, key 'schema_version': expected a whole number"),
             ("UPDATE meta SET value = '{unclosed: [' WHERE key = 'config'",
              "table meta, key 'config': not the experiment's YAML"),
             ("UPDATE meta SET value = '- a list' WHERE key = 'config'",
              "table meta, key 'config': expected the experiment's mapping"),
             ("UPDATE worlds SET resolution = NULL", "table worlds, world"),
             ("UPDATE worlds SET top = x'00'", "table worlds, world"))
    for index, (statement, problem) in enumerate(cases):
        damaged = copy_database(two_experiments[0], tmp_path / f"damaged{index}")
        execute(damaged, statement)
        before = tree_digest(tmp_path)
        result = kinolab("report", damaged, "--out", tmp_path / "report")
        assert_one_line_error(result, str(damaged / "results.sqlite"), problem)
        assert tree_digest(tmp_path) == before
        assert not (tmp_path / "report").exists()


def test_garbage_trajectories_or_trees_are_refused_naming_table_and_column(kinolab,
                                                                          two_experiments,
                                                                          tmp_path):
    """Before: pandas' ParserError, a KeyError or "cannot reshape array" from a figure ("please
    report it"); now one line naming the database, the table and its column, and a damaged
    header or a blob is refused before the report is begun."""
    source = two_experiments[0]

    def stored(table, csv):  # a row of `table` for every run
        return f"INSERT OR REPLACE INTO {table} (run_hash, csv) SELECT run_hash, {csv} FROM runs"

    cases = ((stored("trajectories", "'garbage'"), "table trajectories, column csv",
              "lacks t, x, y, z"),
             (stored("trees", "x'00ff00ff'"), "table trees, column csv",
              "expected CSV text, got an SQLite blob"),
             (stored("trees", "'edge,point' || char(10) || '1,\"2'"), "table trees, column csv",
              "lacks x, y, z, state, closed"))
    for index, (statement, *problem) in enumerate(cases):
        damaged = copy_database(source, tmp_path / f"damaged{index}")
        execute(damaged, statement)
        before = tree_digest(tmp_path)
        result = kinolab("report", damaged, "--out", tmp_path / "report")
        assert_one_line_error(result, str(damaged / "results.sqlite"), *problem)
        assert tree_digest(tmp_path) == before
        assert not (tmp_path / "report").exists()
    # Text where numbers belong: found when a figure reads the row, and named.
    damaged = copy_database(source, tmp_path / "numbers")
    execute(damaged, stored("trajectories", "'t,x,y,z' || char(10) || 'soon,1,2,3'"))
    result = kinolab("report", damaged, "--out", tmp_path / "numbers_report")
    assert_one_line_error(result, str(damaged / "results.sqlite"), "table trajectories, column csv",
                          "the CSV's column 't' holds text where numbers belong")


def test_an_out_that_is_or_lies_under_a_file_is_refused(kinolab, two_experiments, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    for out in (blocker, blocker / "report", blocker / "deeper" / "report"):
        result = kinolab("report", two_experiments[0], "--out", out)
        assert_one_line_error(result, str(blocker), "is not a directory")
    assert_one_line_error(kinolab("report", two_experiments[0], "--out", ""), "--out is empty")
    assert blocker.read_text() == "not a directory"


@pytest.mark.parametrize("content, problem", [
    (bytes(range(128, 256)) * 4, "not a sampling study's CSV"),
    (b"a,b\n1,2\n", "expected the columns sampler, alpha, mean_nearest"),
    (b"", "not a sampling study's CSV"),
    (b"sampler,alpha,mean_nearest\nuniform,high,low\n", "holds text where numbers belong"),
])
def test_a_garbage_sampling_study_is_refused_before_the_report_is_begun(
        kinolab, two_experiments, tmp_path, content, problem):
    study = tmp_path / "summary.csv"
    study.write_bytes(content)
    result = kinolab("report", two_experiments[0], "--out", tmp_path / "report",
                     "--sampling-study", study)
    assert_one_line_error(result, str(study), problem)
    assert not (tmp_path / "report").exists()
    missing = kinolab("report", two_experiments[0], "--out", tmp_path / "report",
                      "--sampling-study", tmp_path / "nowhere.csv")
    assert_one_line_error(missing, "nowhere.csv", "No such file")


def test_two_experiments_are_pooled_only_when_asked_and_then_labelled(
        kinolab, two_experiments, tmp_path):
    first, second = two_experiments
    refused = kinolab("report", first, second, "--out", tmp_path / "mixed")
    assert_one_line_error(refused, "hostile_report@", "--allow-mixed")
    assert not (tmp_path / "mixed").exists()
    mixed = kinolab("report", first, second, "--out", tmp_path / "mixed", "--allow-mixed")
    assert mixed.returncode == 0, mixed.stderr
    summary = (tmp_path / "mixed" / "tables" / "status_counts.md").read_text()
    labelled = [line for line in summary.splitlines() if "eager (hostile_report@" in line]
    assert len(labelled) == 2, summary  # one row per experiment, none pooled
    assert "2 experiments side by side" in (tmp_path / "mixed" / "index.html").read_text()
    # Two copies of one experiment (its shards, say) need no flag.
    copy = copy_database(first, tmp_path / "copy")
    same = kinolab("report", first, copy, "--out", tmp_path / "same")
    assert same.returncode == 0, same.stderr


def test_export_refuses_an_empty_out_instead_of_writing_here(kinolab, two_experiments,
                                                             tmp_path):
    here = tmp_path / "here"
    here.mkdir()
    result = kinolab("export", two_experiments[0], "--format", "ompl", "", cwd=here)
    assert_one_line_error(result, "OUT is empty")
    assert list(here.iterdir()) == []
