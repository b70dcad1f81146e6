#include "kinolab/world/world.hpp"

#include <algorithm>
#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/core/process.hpp"
#include "kinolab/core/text.hpp"
#include "kinolab/world/world_spec.hpp"

namespace kinolab {

World::World(std::string name, std::uint64_t spec_hash, VoxelGrid grid, Esdf esdf)
    : name_(std::move(name)),
      spec_hash_(spec_hash),
      grid_(std::move(grid)),
      esdf_(std::move(esdf)),
      bounds_(grid_.bounds()) {}

World::World(std::string name, std::uint64_t spec_hash, VoxelGrid grid, Esdf esdf,
             const Box& bounds)
    : World(std::move(name), spec_hash, std::move(grid), std::move(esdf)) {
  const Box& box = grid_.bounds();
  const double slack = 1e-9;
  if (!((bounds.min.array() >= box.min.array() - slack).all() &&
        (bounds.max.array() <= box.max.array() + slack).all() &&
        (bounds.min.array() < bounds.max.array()).all())) {
    throw InvalidArgument("World " + name_ + ": the domain " + formatPoint(bounds.min) + " to " +
                          formatPoint(bounds.max) + " is not a box inside the grid's " +
                          formatPoint(box.min) + " to " + formatPoint(box.max));
  }
  bounds_ = bounds;
}

VoxelGrid World::buildGrid(const WorldSpec& spec) {
  VoxelGrid grid(spec.bounds, spec.resolution, spec.layout);
  for (std::size_t i = 0; i < spec.generators.size(); ++i) {
    Rng rng = Rng::derive(spec.seed, "world-generator", i);
    try {
      spec.generators[i].generator->apply(grid, rng);
    } catch (const ConfigError& error) {  // a refusal that needs the bounds (a work cap)
      throw ConfigError("world '" + spec.name + "', generators[" + std::to_string(i) + "] (" +
                        spec.generators[i].type + "): " + error.what());
    }
  }
  grid.compactBricks();
  return grid;
}

std::shared_ptr<const World> World::build(const WorldSpec& spec) {
  return whileDoing("building the world '" + spec.name + "'", [&] {
    VoxelGrid grid = buildGrid(spec);
    Esdf esdf =
        spec.layout == GridLayout::kBricked ? Esdf::truncated(grid, spec.truncation) : Esdf(grid);
    return std::make_shared<const World>(spec.name, spec.hash(), std::move(grid), std::move(esdf));
  });
}

void World::requireExactDistancesTo(double reach, const std::string& who) const {
  if (esdf_.truncation() > reach) return;
  // Rounded up to the millimetre: a truncation of that much is enough.
  throw InvalidArgument(who + ": world '" + name_ + "' is sparse with distances exact to " +
                        formatNumber(esdf_.truncation()) + " m, and it reads them to " +
                        formatNumber(std::ceil(reach * 1000.0) / 1000.0) +
                        " m: build the world with a larger truncation");
}

bool World::segmentFree(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius,
                        double tolerance) const {
  if (!(radius >= 0.0 && radius < INFINITY && tolerance > 0.0 && tolerance < INFINITY)) {
    throw InvalidArgument("World::segmentFree: radius " + formatNumber(radius) + " and tolerance " +
                          formatNumber(tolerance) +
                          " must be finite, the radius >= 0 and the tolerance > 0");
  }
  const double length = (b - a).norm();
  if (!(length < INFINITY) || !bounds_.contains(a) || !bounds_.contains(b)) return false;
  // The box is convex: both ends inside keep the segment inside. A traced point with
  // clearance C >= radius proves the next C - radius + tolerance metres free.
  for (double s = 0.0;;) {
    const double c = esdf_.clearance(a + (b - a) * (length > 0.0 ? s / length : 0.0));
    if (c < radius) return false;
    if (s >= length) return true;
    s = std::min(length, s + c - radius + tolerance);
  }
}

}  // namespace kinolab
