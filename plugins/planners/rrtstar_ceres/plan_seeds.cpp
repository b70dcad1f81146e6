#include "plan_seeds.hpp"

#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include "kinolab/core/random.hpp"

namespace kinolab::rrt {

void PlanSeeds::begin(std::uint64_t seed) {
  seed_ = seed;
  streams_ = 0;
  // The streams OMPL keeps private, out of reach of setLocalSeed(): the informed sampler's
  // (PathLengthDirectInfSampler::rng_, once a solution bounds the samples), BIT*'s and ABIT*'s
  // sample-count coin (bitstar::ImplicitGraph::rng_) and the nearest-neighbour structures' choice
  // of pivots (GreedyKCenters::rng_ in GNAT). Each takes the next seed of OMPL's process-wide
  // generator when it is constructed, and a plan constructs them, after this call, in the same
  // order every time. ompl::RNG::setSeed() re-seeds that generator even after it has handed out
  // seeds (RNGSeedGenerator::setSeed in util/src/RandomNumbers.cpp, OMPL 1.5 to 2.0); it logs an
  // error that a new seed will not make sampling deterministic, true of the streams made before the
  // call, which no plan uses, hence silenced. The generator is shared by the whole process: two
  // plans in parallel threads would interleave their draws (kinolab plans one at a time).
  auto seed_generator =
      static_cast<std::uint32_t>(Rng::derive(seed, "ompl_seed_generator").nextU64());
  if (seed_generator == 0) seed_generator = 1;  // OMPL ignores 0
  const ompl::msg::LogLevel level = ompl::msg::getLogLevel();
  ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
  ompl::RNG::setSeed(seed_generator);
  ompl::msg::setLogLevel(level);
}

std::uint32_t PlanSeeds::next() {
  return static_cast<std::uint32_t>(Rng::derive(seed_, "ompl_stream", streams_++).nextU64());
}

namespace {

class SeededStateSampler final : public ompl::base::RealVectorStateSampler {
 public:
  SeededStateSampler(const ompl::base::StateSpace* space, std::uint32_t seed)
      : ompl::base::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

}  // namespace

ompl::base::StateSamplerPtr SeededRealVectorStateSpace::allocDefaultStateSampler() const {
  return std::make_shared<SeededStateSampler>(this, seeds_->next());
}

}  // namespace kinolab::rrt
