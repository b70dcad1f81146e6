"""What the command-line suites (tests/cli, tests/hostile) share: where the sources and the
kinolab binary are, the small forest world, a tiny experiment and a command's JSON summary."""

import json
import os
from pathlib import Path

SOURCE_DIR = Path(os.environ.get("KINOLAB_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY = os.environ.get("KINOLAB_BIN", str(SOURCE_DIR / "build" / "framework" / "kinolab"))
# A small forest world spec (10 m x 10 m x 3 m) the command tests plan in.
SMALL_FOREST = (SOURCE_DIR / "tests" / "support" / "small_forest.yaml").read_text()


def last_json(result):
    """The JSON summary a command prints as its last line."""
    return json.loads(result.stdout.strip().splitlines()[-1])


def tiny_experiment(directory, name, seed, queries=3):
    """A planning experiment of `queries` eager runs in the small forest, written into
    `directory` (beside its world file); its seed sets its config hash. Returns its path."""
    world = directory / "world.yaml"
    world.write_text(SMALL_FOREST)
    path = directory / f"{name}_{seed}.yaml"
    path.write_text(f"""kind: planning
name: {name}
seed: {seed}
worlds:
  - id: small
    spec: {world}
queries:
  random: {{count: {queries}, min_distance: 4, max_distance: 9}}
planners:
  - id: eager
    type: eager_mp_astar
    sampler: {{type: uniform, params: {{samples_per_axis: 3}}}}
budget: {{time: 5}}
""")
    return path
