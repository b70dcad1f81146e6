// The x-y cells of a lattice that the column guides search (vehicle_map.cpp's columnGuides,
// level_guides.cpp's levelColumnGuides): which a body cannot stand in, and which are opened
// round a vehicle or a goal. Private to framework/src/flight.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "kinolab/flight/vehicle_map.hpp"

namespace kinolab::column_cells {

/// The x-y cell of `lattice` holding `p` (clamped to the lattice).
Eigen::Vector2i cellOf(const VoxelGrid& lattice, const Eigen::Vector3d& p);

/// Opens in `cells` (x-y cells of `lattice`, x slowest) the cell of `at` and those whose
/// centres lie within `room` of it.
void openRound(const VoxelGrid& lattice, std::span<std::uint8_t> cells, const Eigen::Vector3d& at,
               double room);

/// Opens in `cells` the cell of each point of `trail` whose height lies in [z_low, z_high]:
/// where the vehicle has flown, its body fits.
void openTrail(const VoxelGrid& lattice, std::span<std::uint8_t> cells,
               std::span<const Eigen::Vector3d> trail, double z_low, double z_high);

/// Per x-y cell of `lattice` (x slowest): 1 where a column with an obstacle (`obstacles`) in
/// the heights [z_low, z_high] lies within `radius` of the cell's centre, or where the centre
/// lies within `inset` of the lattice's sides in x or y.
std::vector<std::uint8_t> closedCells(const VoxelGrid& lattice, const ObstacleColumns& obstacles,
                                      double radius, double z_low, double z_high, double inset);

/// A search's way to node `at`, start first: `at` and its parents (`parent`, -1 at the start).
std::vector<std::size_t> wayTo(std::span<const std::int64_t> parent, std::size_t at);

}  // namespace kinolab::column_cells
