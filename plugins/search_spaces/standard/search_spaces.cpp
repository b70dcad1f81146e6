// How a motion-primitive search tells states apart: lattice (exact on a control grid's
// lattice) and cells (one state per position cell and velocity bin, as hybrid A* keeps them).
#include "kinolab/core/fields.hpp"
#include "kinolab/core/plugin.hpp"
#include "kinolab/search/search_policies.hpp"

KINOLAB_REGISTER_PLUGINS(registrar) {
  using namespace kinolab;
  registrar.add<SearchSpace>(
      "lattice", "every derivative rounded finely: exact on a control grid's lattice (optimal)",
      declareFields<LatticeSpace::Resolution>(), [](const ParameterSet& p) {
        return std::make_unique<LatticeSpace>(readFields<LatticeSpace::Resolution>(p));
      });
  registrar.add<SearchSpace>(
      "cells",
      "one state per position cell and velocity bin, as hybrid A* keeps them (not optimal)",
      declareFields<CellSpace::Cells>(), [](const ParameterSet& p) {
        return std::make_unique<CellSpace>(readFields<CellSpace::Cells>(p));
      });
}
