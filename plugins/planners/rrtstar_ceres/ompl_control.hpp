#pragma once

#include <memory>

#include "kinolab/planner/planner.hpp"

namespace kinolab::rrt {

/// `ompl_control`'s parameters, statistics and factory (ompl_control.cpp).
ParameterSpecs omplControlParameters();
MetricSpecs omplControlStatistics();
std::unique_ptr<Planner> makeOmplControl(const ParameterSet& parameters);

}  // namespace kinolab::rrt
