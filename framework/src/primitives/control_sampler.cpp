#include "kinolab/primitives/control_sampler.hpp"

#include <cmath>

#include "kinolab/core/error.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab {

std::vector<Eigen::Vector3d> ControlSampler::sample(const Eigen::Vector3d& u_max,
                                                    std::uint64_t seed) const {
  if (!(u_max.array() > 0.0).all() || !u_max.allFinite()) {
    throw InvalidArgument("control sampler: u_max must be positive and finite on every axis");
  }
  Rng rng = Rng::derive(seed, "control_sampler");
  std::vector<Eigen::Vector3d> controls = doSample(u_max, rng);
  if (controls.empty()) throw PluginError("control sampler returned an empty control set");
  for (const auto& control : controls) {
    if (!control.allFinite() || (control.array().abs() > u_max.array()).any()) {
      throw PluginError("control sampler returned a control outside [-u_max, u_max]: (" +
                        formatNumber(control.x()) + ", " + formatNumber(control.y()) + ", " +
                        formatNumber(control.z()) + ")");
    }
  }
  return controls;
}

std::vector<Eigen::Vector3d> controlGrid(const std::vector<double>& unit_values,
                                         const Eigen::Vector3d& u_max) {
  std::vector<Eigen::Vector3d> controls;
  controls.reserve(unit_values.size() * unit_values.size() * unit_values.size());
  for (const double x : unit_values) {
    for (const double y : unit_values) {
      for (const double z : unit_values) {
        controls.emplace_back(x * u_max.x(), y * u_max.y(), z * u_max.z());
      }
    }
  }
  return controls;
}

KINOLAB_DEFINE_PLUGIN_REGISTRY(ControlSampler, "sampler", "samplers",
                               "control-set samplers U_M for motion primitives", 2)

}  // namespace kinolab
