#!/usr/bin/env bash
# The main job: install what is missing, build, run the quick paper reproduction
# (experiments/quick.yaml: every planner on 20 forest queries) into out/quick/results.sqlite,
# run the paper's Table I sampling study beside it, write the report
# (out/quick/report/index.html), build the demo worlds with their pictures into
# out/worlds/, and plan one forest query with eager and lazy MP-A* and the TGK analogue into
# out/plan/. Run again, it resumes (nothing runs twice).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_debian.sh
bash scripts/build.sh
./build/framework/kinolab run experiments/quick.yaml --out out/quick -j 2 --resume
./build/framework/kinolab sampling-study experiments/paper_table1_samplers.yaml \
  --out out/quick/sampling_study/paper_table1_samplers
./build/framework/kinolab report out/quick --out out/quick/report
for world in forest complex walls geb079; do
  ./build/framework/kinolab world "configs/worlds/$world.yaml" --out "out/worlds/$world"
done
for planner in eager_mp_astar lazy_mp_astar; do
  ./build/framework/kinolab plan --world configs/worlds/forest.yaml --planner "$planner" \
    --start 2,2,1.5 --goal 14,12,1.5 --out "out/plan/$planner"
done
./build/framework/kinolab plan --world configs/worlds/forest.yaml --planner rrtstar_ceres \
  --start 2,2,1.5 --goal 14,12,1.5 --out out/plan/rrtstar_ceres
echo "demo: the quick reproduction: out/quick/report/index.html (results in out/quick/results.sqlite);"
echo "      pictures in out/worlds/*/top_view.png and out/worlds/*/esdf_slice.png;"
echo "      Table I in out/quick/sampling_study/paper_table1_samplers/summary.csv;"
echo "      lazy and eager MP-A* and rrtstar_ceres on the forest in out/plan/*/{trajectory,tree}.csv"
