#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "kinolab/world/world.hpp"

namespace kinolab {

/// The connected pieces of a world's free space for a sphere of `radius`: one labelling of the
/// voxels whose centres lie in the world's domain at least radius + half a voxel from every
/// occupied cube (the ESDF at the centre), joined across their faces. Two such voxels with one
/// label are joined by a chain of face neighbours, and every point of the segment between two
/// neighbouring centres is within half a voxel of one of them (the distance is 1-Lipschitz),
/// so a sphere of `radius` moves from one to the other without touching an obstacle: one
/// label means a way exists. Different labels mean none exists along voxel centres at that
/// margin (a way squeezing through a gap narrower than radius + half a voxel may remain).
/// Built once, in time and memory linear in the world's voxels (4 bytes a voxel).
class FreeComponents {
 public:
  /// Throws InvalidArgument when the world's field is truncated at or below the distance
  /// read (a sparse world built with too small a truncation).
  FreeComponents(const World& world, double radius);

  /// The label of the voxel holding `point`, -1 when it is outside the domain or has no room
  /// for the sphere.
  int componentOf(const Eigen::Vector3d& point) const;
  /// Whether `a` and `b` lie in one labelled component.
  bool joined(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
    const int label = componentOf(a);
    return label >= 0 && label == componentOf(b);
  }
  /// How many components there are.
  int count() const { return count_; }
  double radius() const { return radius_; }

 private:
  Eigen::Vector3i dims_;  // the world's voxels (its ESDF's geometry)
  Eigen::Vector3d origin_;
  double resolution_;
  Box bounds_;
  double radius_;
  std::vector<std::int32_t> labels_;  // per voxel in grid order, -1 without room
  int count_ = 0;
};

}  // namespace kinolab
