// `uniform`: the evenly spaced control grid of motion-primitive planners (e.g. Liu et al.,
// "Search-based Motion Planning for Aggressive Flight in SE(3)", RA-L 2018).
#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {
namespace {

/// n evenly spaced values per axis over [-u_max, u_max], ends included; n^3 controls.
class UniformSampler final : public ControlSampler {
 public:
  explicit UniformSampler(const ParameterSet& parameters)
      : samples_per_axis_(static_cast<int>(parameters.integer("samples_per_axis"))) {}

 protected:
  std::vector<Eigen::Vector3d> doSample(const Eigen::Vector3d& u_max, Rng& /*rng*/) const override {
    std::vector<double> values;
    for (int i = 0; i < samples_per_axis_; ++i) {
      values.push_back(samples_per_axis_ == 1 ? 0.0 : -1.0 + 2.0 * i / (samples_per_axis_ - 1));
    }
    return controlGrid(values, u_max);
  }

 private:
  int samples_per_axis_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<ControlSampler>(
      "uniform", "evenly spaced grid of n values per axis over [-u_max, u_max] (n^3 controls)",
      ParameterSpecs().integer("samples_per_axis", 3, 1, 64,
                               "values per axis n, ends included (1 gives the zero control)"),
      [](const ParameterSet& parameters) { return std::make_unique<UniformSampler>(parameters); });
}
