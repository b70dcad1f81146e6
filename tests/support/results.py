"""Reading a results database in the command tests: what two runs of the same experiment
must agree on."""

import sqlite3


def machine_figures(db):
    """The names the database declares as figures of the machine (`metrics.clock`: times,
    memory, the start date, RRT*'s anytime costs sampled on the clock)."""
    return {name for (name,) in db.execute("SELECT name FROM metrics WHERE clock = 1")}


def rows(database):
    """Every run and every statistic by run hash, without the figures of the machine."""
    with sqlite3.connect(database) as db:
        db.row_factory = sqlite3.Row
        machine = machine_figures(db)
        runs = {row["run_hash"]: {k: row[k] for k in row.keys() if k not in machine}
                for row in db.execute("SELECT * FROM runs")}
        for run_hash, name, value in db.execute("SELECT run_hash, name, value FROM statistics"):
            if name not in machine:
                runs[run_hash][f"stat.{name}"] = value
    return runs


def meta(database):
    with sqlite3.connect(database) as db:
        return dict(db.execute("SELECT key, value FROM meta"))
