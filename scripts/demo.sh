#!/usr/bin/env bash
# The main job: install what is missing, build, and build the demo worlds with their
# pictures into out/worlds/. (The paper reproduction replaces this once the experiment
# runner exists.)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_debian.sh
bash scripts/build.sh
for world in forest complex walls geb079; do
  ./build/framework/kinolab world "configs/worlds/$world.yaml" --out "out/worlds/$world"
done
echo "demo: pictures in out/worlds/*/top_view.png and out/worlds/*/esdf_slice.png"
