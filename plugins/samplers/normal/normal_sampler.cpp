// `normal`: the paper's proposal (Wang et al., "Towards Efficient Motion Planning for UAVs:
// Lazy A* Search with Motion Primitives", Table I): controls concentrated around zero by a
// normal distribution per axis, truncated to [-u_max, u_max].
#include <algorithm>
#include <boost/math/distributions/normal.hpp>

#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace kinolab {
namespace {

/// Per axis, the normal distribution N(0, (sigma u_max)^2) truncated to [-u_max, u_max]:
/// - `quantile`: n deterministic values per axis, its quantiles at i / (n - 1) (so the ends
///   +-u_max are included, as in the uniform grid), and their n^3 grid;
/// - `random`: n^3 controls, each axis drawn independently from it (seeded).
class NormalSampler final : public ControlSampler {
 public:
  explicit NormalSampler(const ParameterSet& parameters)
      : samples_per_axis_(static_cast<int>(parameters.integer("samples_per_axis"))),
        quantile_variant_(parameters.text("variant") == "quantile"),
        normal_(0.0, parameters.real("sigma")),
        lower_mass_(boost::math::cdf(normal_, -1.0)),
        mass_(boost::math::cdf(normal_, 1.0) - lower_mass_) {}

 protected:
  std::vector<Eigen::Vector3d> doSample(const Eigen::Vector3d& u_max, Rng& rng) const override {
    if (quantile_variant_) {
      std::vector<double> values;
      for (int i = 0; i < samples_per_axis_; ++i) {
        values.push_back(
            truncatedQuantile(samples_per_axis_ == 1 ? 0.5 : double(i) / (samples_per_axis_ - 1)));
      }
      return controlGrid(values, u_max);
    }
    const int count = samples_per_axis_ * samples_per_axis_ * samples_per_axis_;
    return independentControls(count, u_max, [&] { return truncatedQuantile(rng.uniform01()); });
  }

 private:
  /// The p-quantile, in [-1, 1], of the unit-bounded truncated normal.
  double truncatedQuantile(double p) const {
    if (p <= 0.0) return -1.0;
    if (p >= 1.0) return 1.0;
    if (p == 0.5) return 0.0;  // exact symmetry around zero
    return std::clamp(boost::math::quantile(normal_, lower_mass_ + p * mass_), -1.0, 1.0);
  }

  int samples_per_axis_;
  bool quantile_variant_;
  boost::math::normal_distribution<double> normal_;
  double lower_mass_;
  double mass_;
};

}  // namespace
}  // namespace kinolab

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<ControlSampler>(
      "normal",
      "normal distribution per axis truncated to [-u_max, u_max]: quantile grid or seeded draws "
      "(the paper's proposal)",
      ParameterSpecs()
          .integer("samples_per_axis", 5, 1, 64,
                   "quantile: n values per axis (n^3 controls); random: n^3 draws")
          .choice("variant", "quantile", {"quantile", "random"},
                  "quantile: deterministic quantiles at i/(n-1); random: seeded draws")
          .real("sigma", 0.5, 0.05, 10.0,
                "standard deviation as a fraction of u_max (large sigma tends to uniform)"),
      [](const ParameterSet& parameters) { return std::make_unique<NormalSampler>(parameters); });
}
