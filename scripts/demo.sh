#!/usr/bin/env bash
# The main job: install what is missing, build, run the quick paper reproduction
# (experiments/quick.yaml: every planner on 40 queries of the dense forest, where most
# straight lines are blocked) into out/quick/results.sqlite, the paper's Table I sampling
# study under every reading and the lazy-regime sweeps (experiments/lazy_regime/) beside it,
# write the report (out/quick/report/index.html), build the demo worlds with their pictures
# into out/worlds/, and plan one dense-forest query with eager and lazy MP-A* and the TGK
# analogue into out/plan/, and fly one closed-loop flight into out/fly/. Run again, it resumes
# (nothing runs twice). About 3 minutes on 2 cores after the build.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_debian.sh
bash scripts/build.sh
kinolab=./build/framework/kinolab
python=/usr/bin/python3
[[ -x "$python" ]] || python="$(command -v python3)"
# A results directory an older kinolab wrote cannot be resumed into (its schema differs): it
# is kept beside, as DIR.schema-N.TIME, and the run starts anew.
set_aside_if_old() {
  [[ -f "$1/results.sqlite" ]] || return 0
  local stored current
  stored=$("$python" -c 'import sqlite3, sys
row = sqlite3.connect(sys.argv[1]).execute(
    "SELECT value FROM meta WHERE key = '"'"'schema_version'"'"'").fetchone()
print(row[0] if row else 1)' "$1/results.sqlite")
  current=$(PYTHONPATH=analysis "$python" -c \
    'from kinolab_analysis.data import SCHEMA_VERSION; print(SCHEMA_VERSION)')
  if [[ "$stored" != "$current" ]]; then
    mv "$1" "$1.schema-$stored.$(date +%Y%m%dT%H%M%S)"
    echo "demo: $1 held results of schema $stored (this kinolab writes $current): kept as" \
         "$1.schema-$stored.*, running anew"
  fi
}
set_aside_if_old out/quick
$kinolab run experiments/quick.yaml --out out/quick -j 2 --resume
$kinolab sampling-study experiments/paper_table1_samplers.yaml \
  --out out/quick/sampling_study/paper_table1_samplers
for sweep in edge_cost density controls epsilon order esdf_resolution edge_cost_density; do
  set_aside_if_old "out/quick/lazy_regime/$sweep"
  $kinolab run "experiments/lazy_regime/$sweep.yaml" --out "out/quick/lazy_regime/$sweep" \
    -j 2 --resume
done
$kinolab report out/quick --out out/quick/report
for world in dense_forest forest complex walls geb079; do
  $kinolab world "configs/worlds/$world.yaml" --out "out/worlds/$world"
done
for planner in eager_mp_astar lazy_mp_astar rrtstar_ceres; do
  $kinolab plan --world configs/worlds/dense_forest.yaml --planner "$planner" \
    --start 2,2,1.5 --goal 14,12,1.5 --out "out/plan/$planner"
done
# One closed-loop flight through the dense forest, seen only through a depth camera.
$kinolab fly --world configs/worlds/dense_forest.yaml --planner lazy_mp_astar \
  --set sampler.samples_per_axis=5 --start 2,2,1.5 --goal 30,30,1.5 --out out/fly/lazy_mp_astar
echo "demo: the quick reproduction: out/quick/report/index.html (results in out/quick/results.sqlite;"
echo "      lazy-regime sweeps in out/quick/lazy_regime/*; Table I and its readings in"
echo "      out/quick/sampling_study/paper_table1_samplers/{summary,readings}.csv);"
echo "      pictures in out/worlds/*/top_view.png and out/worlds/*/esdf_slice.png;"
echo "      lazy and eager MP-A* and rrtstar_ceres on the dense forest in out/plan/*/{trajectory,tree}.csv;"
echo "      a closed-loop flight of lazy MP-A* in out/fly/lazy_mp_astar/ (flown.csv, replans.csv, known_map.bt);"
echo "      3D views: out/quick/report/view_dense_forest.html, out/plan/*/view.html, out/fly/*/view.html"
