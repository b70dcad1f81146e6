#include "kinolab/world/free_components.hpp"

#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {

FreeComponents::FreeComponents(const World& world, double radius)
    : dims_(world.esdf().dims()),
      origin_(world.esdf().origin()),
      resolution_(world.esdf().resolution()),
      bounds_(world.bounds()),
      radius_(radius) {
  if (!(radius >= 0.0 && radius < INFINITY)) {
    throw InvalidArgument("FreeComponents: radius " + formatNumber(radius) +
                          " must be finite and >= 0");
  }
  const Esdf& field = world.esdf();
  const double threshold = radius + 0.5 * resolution_;
  world.requireExactDistancesTo(threshold, "the free components at radius " + formatNumber(radius));
  const auto nx = static_cast<std::size_t>(dims_.x());
  const auto ny = static_cast<std::size_t>(dims_.y());
  const auto nz = static_cast<std::size_t>(dims_.z());
  // -2: room, not yet labelled; -1: no room.
  labels_.assign(nx * ny * nz, -1);
  for (std::size_t x = 0, i = 0; x < nx; ++x) {
    for (std::size_t y = 0; y < ny; ++y) {
      for (std::size_t z = 0; z < nz; ++z, ++i) {
        const Eigen::Vector3d centre =
            origin_ +
            (Eigen::Vector3d(static_cast<double>(x), static_cast<double>(y), static_cast<double>(z))
                 .array() +
             0.5)
                    .matrix() *
                resolution_;
        if (bounds_.contains(centre) && field.voxelDistance(i) >= threshold) labels_[i] = -2;
      }
    }
  }
  // Flood fill, face neighbours; the steps in index space of the six faces.
  const std::size_t steps[3] = {ny * nz, nz, 1};
  std::vector<std::size_t> frontier;
  for (std::size_t seed = 0; seed < labels_.size(); ++seed) {
    if (labels_[seed] != -2) continue;
    labels_[seed] = count_;
    frontier.assign(1, seed);
    while (!frontier.empty()) {
      const std::size_t i = frontier.back();
      frontier.pop_back();
      const std::size_t at[3] = {i / steps[0], i / nz % ny, i % nz};
      const std::size_t size[3] = {nx, ny, nz};
      for (int axis = 0; axis < 3; ++axis) {
        for (const bool up : {false, true}) {
          if (up ? at[axis] + 1 >= size[axis] : at[axis] == 0) continue;
          const std::size_t j = up ? i + steps[axis] : i - steps[axis];
          if (labels_[j] != -2) continue;
          labels_[j] = count_;
          frontier.push_back(j);
        }
      }
    }
    ++count_;
  }
}

int FreeComponents::componentOf(const Eigen::Vector3d& point) const {
  if (!bounds_.contains(point)) return -1;
  std::size_t index = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const double cell = std::floor((point[axis] - origin_[axis]) / resolution_);
    if (!(cell >= 0.0 && cell < dims_[axis])) return -1;
    index = index * static_cast<std::size_t>(dims_[axis]) + static_cast<std::size_t>(cell);
  }
  return labels_[index];
}

}  // namespace kinolab
