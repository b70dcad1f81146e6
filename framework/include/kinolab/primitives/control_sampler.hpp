#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "kinolab/core/plugin_registry.hpp"
#include "kinolab/core/random.hpp"

namespace kinolab {

/// The control set U_M of a motion-primitive planner: constant controls (the highest
/// derivative of the integrator chain) within [-u_max, u_max] per axis. Samplers are plugins
/// (`plugins/samplers/`); a planner draws its set once, when it is configured.
class ControlSampler {
 public:
  virtual ~ControlSampler() = default;

  /// The control set for per-axis bounds `u_max` (all > 0). The same parameters, bounds and
  /// seed give the same set, bit for bit. Checks the plugin's output: a non-empty set of
  /// finite controls within the bounds (a plugin that breaks this throws PluginError).
  std::vector<Eigen::Vector3d> sample(const Eigen::Vector3d& u_max, std::uint64_t seed) const;

 protected:
  /// The set itself; `rng` is a stream derived from the seed for this sampler alone.
  virtual std::vector<Eigen::Vector3d> doSample(const Eigen::Vector3d& u_max, Rng& rng) const = 0;
};

/// The cartesian product of per-axis values given as fractions of u_max in [-1, 1] (x
/// outermost, z innermost): n values give n^3 controls.
std::vector<Eigen::Vector3d> controlGrid(const std::vector<double>& unit_values,
                                         const Eigen::Vector3d& u_max);

/// `count` controls whose components are drawn independently: `unit_draw()` returns a
/// fraction of u_max in [-1, 1], called for x, y, z of each control in turn.
template <typename UnitDraw>
std::vector<Eigen::Vector3d> independentControls(int count, const Eigen::Vector3d& u_max,
                                                 UnitDraw&& unit_draw) {
  std::vector<Eigen::Vector3d> controls;
  controls.reserve(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d control;
    for (int axis = 0; axis < 3; ++axis) control[axis] = unit_draw() * u_max[axis];
    controls.push_back(control);
  }
  return controls;
}

template <>
PluginRegistry<ControlSampler>& pluginRegistry<ControlSampler>();

}  // namespace kinolab
