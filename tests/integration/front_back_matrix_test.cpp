// Every front end with every back end (issue 53): lazy MP-A*, hybrid A*, BIT*, RRT* and the
// grid search, each followed by none, bspline, corridor_minco and ego_bspline, plan the same
// forest queries through Planner::plan(), so the independent checker judges every output.
// Work-bounded (iterations, not seconds): the same counts on every machine.
#include <gtest/gtest.h>

#include <cstdio>

#include "kinolab/planner/planner.hpp"
#include "support/planning.hpp"

namespace kinolab {
namespace {

struct FrontEnd {
  std::string id;
  std::string key;
  std::vector<std::string> items;
};

const std::vector<FrontEnd>& frontEnds() {
  static const std::vector<FrontEnd> list = {
      {"lazy", "lazy_mp_astar", {}},
      {"hybrid", "hybrid_astar", {}},
      {"bitstar",
       "ompl_geometric",
       {"planner=bitstar", "stop_at_first=true", "max_iterations=5000"}},
      {"rrtstar", "rrtstar", {"refine_iterations=200", "max_iterations=20000"}},
      {"grid", "grid_astar", {"algorithm=jps"}}};
  return list;
}

class FrontBackMatrix : public ::testing::TestWithParam<std::string> {};

TEST_P(FrontBackMatrix, EveryFrontEndFollowedByThisBackEndPlansCheckedTrajectories) {
  const auto world = test::smallWorld("forest");
  const std::vector<PlanningQuery> queries = test::randomQueries(*world, 8, 83, 5.0, 10.0, 0.6);
  int total = 0;
  for (const FrontEnd& front : frontEnds()) {
    std::vector<std::string> items = front.items;
    items.push_back("time_limit=0");
    items.push_back("back_end=" + GetParam());
    ConfiguredPlanner configured = configurePlanner(front.key, test::assignments(items));
    configured.planner->setup({world, 5});
    int valid = 0;
    for (const PlanningQuery& query : queries) {
      const PlanResult result = configured.planner->plan(query, Budget{INFINITY, 200000});
      SCOPED_TRACE(front.id + " + " + GetParam() + ": " + result.message);
      // Whatever the outcome, never a trajectory the checker refuses.
      EXPECT_NE(result.status, PlanStatus::kInvalidTrajectory) << result.check.detail;
      if (result.status == PlanStatus::kExact && result.check.valid) ++valid;
    }
    std::printf("[ %s + %s ] valid %d / %zu\n", front.id.c_str(), GetParam().c_str(), valid,
                queries.size());
    EXPECT_GE(valid, 7) << front.id << " + " << GetParam();
    total += valid;
  }
  EXPECT_GE(total, 38);  // of 40
}

INSTANTIATE_TEST_SUITE_P(BackEnds, FrontBackMatrix,
                         ::testing::Values("none", "bspline", "corridor_minco", "ego_bspline"),
                         [](const auto& key) { return key.param; });

}  // namespace
}  // namespace kinolab
