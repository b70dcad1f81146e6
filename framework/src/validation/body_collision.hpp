// The body's collision test against a world's obstacles, the one part of the independent
// checker that needs FCL: it lives in a module (kinolab_modules/kinolab_fcl_body.so beside the
// framework library) loaded when a checker of a body first needs it, so a process that checks
// only point robots never loads FCL and its dependencies.
#pragma once

#include <Eigen/Core>
#include <memory>

#include "kinolab/world/world.hpp"

namespace kinolab {

/// A sphere of the body's radius against the occupied voxels' cubes of one world.
class BodyCollision {
 public:
  virtual ~BodyCollision() = default;
  /// True when the sphere at `position` meets the cube of an occupied voxel with a free
  /// neighbour (with the test of the centre, every cube: TrajectoryChecker::collides()).
  virtual bool collides(const Eigen::Vector3d& position) const = 0;
  /// Makes every tile's tree now (shared by every checker of the world).
  virtual void makeEveryTile() const = 0;
};

/// The FCL test of a sphere of `radius` in `world` (which outlives it), from the module, loaded
/// on the first call; a KinolabError naming the module's file when it cannot be loaded.
std::unique_ptr<BodyCollision> makeBodyCollision(const World& world, double radius);

}  // namespace kinolab
