"""Reading a results database in the command tests: what two runs of the same experiment
must agree on."""

import sqlite3

MACHINE_COLUMNS = {"planning_time_ms", "wall_time_ms", "peak_memory_mb", "started_at"}


def rows(database):
    """Every run and every statistic by run hash, without the figures that depend on the
    machine (times, memory, start time, anytime costs sampled on the clock)."""
    with sqlite3.connect(database) as db:
        db.row_factory = sqlite3.Row
        runs = {row["run_hash"]: {k: row[k] for k in row.keys() if k not in MACHINE_COLUMNS}
                for row in db.execute("SELECT * FROM runs")}
        for run_hash, name, value in db.execute("SELECT run_hash, name, value FROM statistics"):
            # Times, and RRT*'s anytime curve (best_cost_at_<t>ms), depend on the machine.
            if "time" not in name and not name.endswith("ms"):
                runs[run_hash][f"stat.{name}"] = value
    return runs


def meta(database):
    with sqlite3.connect(database) as db:
        return dict(db.execute("SELECT key, value FROM meta"))
