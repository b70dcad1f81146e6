#pragma once

// Every random stream of an OMPL plan from the plan's seed, so that a plan depends on its seed,
// query and parameters only: not on what the process planned before, and the same in a fresh
// process as in a long-lived worker (docs/reliability.md, "Reproducibility"). Included by this
// folder's sources only.
#include <ompl/base/spaces/RealVectorStateSpace.h>

#include <cstdint>
#include <memory>
#include <utility>

namespace kinolab::rrt {

/// The seeds of one plan's random streams. OMPL gives every sampler, planner and simplifier a
/// stream of its own (an ompl::RNG) seeded at construction from one process-wide generator,
/// which by default is seeded from the clock. kinolab re-seeds every stream it can reach with
/// next(); begin() restarts that generator for the few streams OMPL keeps private.
class PlanSeeds {
 public:
  /// Starts a plan: the stream counter from 0, and OMPL's seed generator restarted from
  /// `seed`. Call it before the plan builds any OMPL object that draws random numbers.
  void begin(std::uint64_t seed);
  /// The seed of the plan's next stream: the plan's seed and the stream's number mixed, so that
  /// streams differ from each other (two streams of one seed would draw the same numbers) and
  /// the n-th stream of a plan is the same in every run.
  std::uint32_t next();

 private:
  std::uint64_t seed_ = 0;
  std::uint64_t streams_ = 0;
};

/// An OMPL object (planner, simplifier) whose own stream, its protected `rng_`, is seeded.
template <typename Base>
class Seeded : public Base {
 public:
  template <typename... Arguments>
  explicit Seeded(std::uint32_t seed, Arguments&&... arguments)
      : Base(std::forward<Arguments>(arguments)...) {
    this->rng_.setLocalSeed(seed);
  }
};

/// A real vector space whose every state sampler draws from the plan's seeds: OMPL's default
/// sampler included, which the informed samplers (Informed RRT*, BIT*, ABIT*) allocate directly
/// with allocDefaultStateSampler(), bypassing an allocator set with setStateSamplerAllocator().
class SeededRealVectorStateSpace final : public ompl::base::RealVectorStateSpace {
 public:
  SeededRealVectorStateSpace(unsigned int dimension, std::shared_ptr<PlanSeeds> seeds)
      : ompl::base::RealVectorStateSpace(dimension), seeds_(std::move(seeds)) {}

  ompl::base::StateSamplerPtr allocDefaultStateSampler() const override;

 private:
  std::shared_ptr<PlanSeeds> seeds_;
};

}  // namespace kinolab::rrt
