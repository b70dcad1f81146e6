#include "kinolab/world/world.hpp"

#include "kinolab/world/world_spec.hpp"

namespace kinolab {

World::World(std::string name, std::uint64_t spec_hash, VoxelGrid grid, Esdf esdf)
    : name_(std::move(name)),
      spec_hash_(spec_hash),
      grid_(std::move(grid)),
      esdf_(std::move(esdf)),
      bounds_(grid_.bounds()) {}

VoxelGrid World::buildGrid(const WorldSpec& spec) {
  VoxelGrid grid(spec.bounds, spec.resolution);
  for (std::size_t i = 0; i < spec.generators.size(); ++i) {
    Rng rng = Rng::derive(spec.seed, "world-generator", i);
    spec.generators[i]->apply(grid, rng);
  }
  return grid;
}

std::shared_ptr<const World> World::build(const WorldSpec& spec) {
  VoxelGrid grid = buildGrid(spec);
  Esdf esdf(grid);
  return std::make_shared<const World>(spec.name, spec.hash(), std::move(grid), std::move(esdf));
}

}  // namespace kinolab
