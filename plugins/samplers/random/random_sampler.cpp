// `random`: controls drawn uniformly at random, the baseline of the paper's Table I (Wang et
// al., "Towards Efficient Motion Planning for UAVs: Lazy A* Search with Motion Primitives").
#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {
namespace {

/// n^3 controls, each axis drawn independently and uniformly from [-u_max, u_max].
class RandomSampler final : public ControlSampler {
 public:
  explicit RandomSampler(const ParameterSet& parameters)
      : samples_per_axis_(static_cast<int>(parameters.integer("samples_per_axis"))) {}

 protected:
  std::vector<Eigen::Vector3d> doSample(const Eigen::Vector3d& u_max, Rng& rng) const override {
    const int count = samples_per_axis_ * samples_per_axis_ * samples_per_axis_;
    return independentControls(count, u_max, [&rng] { return rng.uniform(-1.0, 1.0); });
  }

 private:
  int samples_per_axis_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<ControlSampler>(
      "random", "n^3 controls, each axis uniform at random in [-u_max, u_max] (seeded)",
      ParameterSpecs().integer("samples_per_axis", 5, 1, 64,
                               "n: the set has n^3 controls, as many as the n-per-axis grids"),
      [](const ParameterSet& parameters) { return std::make_unique<RandomSampler>(parameters); });
}
