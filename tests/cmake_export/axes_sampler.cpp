// An out-of-tree sampler: the zero control and the six axis directions at a fraction of
// u_max, in the spirit of the sparse control sets of early lattice planners.
#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace {

class AxesSampler final : public kinolab::ControlSampler {
 public:
  explicit AxesSampler(double fraction) : fraction_(fraction) {}

 protected:
  std::vector<Eigen::Vector3d> doSample(const Eigen::Vector3d& u_max,
                                        kinolab::Rng& /*rng*/) const override {
    std::vector<Eigen::Vector3d> controls{Eigen::Vector3d::Zero()};
    for (int axis = 0; axis < 3; ++axis) {
      for (const double sign : {-1.0, 1.0}) {
        Eigen::Vector3d control = Eigen::Vector3d::Zero();
        control[axis] = sign * fraction_ * u_max[axis];
        controls.push_back(control);
      }
    }
    return controls;
  }

 private:
  double fraction_;
};

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  registrar.add<kinolab::ControlSampler>(
      "axes", "zero and the six axis directions (out-of-tree test plugin)",
      kinolab::ParameterSpecs().real("fraction", 1.0, 0.0, 1.0, "length as a fraction of u_max"),
      [](const kinolab::ParameterSet& parameters) {
        return std::make_unique<AxesSampler>(parameters.real("fraction"));
      });
}
