// Registers a key that a built-in sampler already has: loading it must fail, adding nothing.
#include "kinolab/core/plugin.hpp"
#include "kinolab/primitives/control_sampler.hpp"

namespace {

class ZeroSampler final : public kinolab::ControlSampler {
 protected:
  std::vector<Eigen::Vector3d> doSample(const Eigen::Vector3d& /*u_max*/,
                                        kinolab::Rng& /*rng*/) const override {
    return {Eigen::Vector3d::Zero()};
  }
};

}  // namespace

KINOLAB_REGISTER_PLUGINS(registrar) {
  const auto factory = [](const kinolab::ParameterSet&) { return std::make_unique<ZeroSampler>(); };
  registrar.add<kinolab::ControlSampler>("zero_first", "registered before the clash", {}, factory);
  registrar.add<kinolab::ControlSampler>("uniform", "clashes with the built-in", {}, factory);
}
