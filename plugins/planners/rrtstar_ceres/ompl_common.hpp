#pragma once

// What the plugin's OMPL planners share (geometric and control): the clock and the planner's
// graph as a search tree for figures. Included by this folder's sources only.
#include <ompl/base/Planner.h>
#include <ompl/base/PlannerData.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>

#include <chrono>
#include <utility>
#include <vector>

#include "kinolab/planner/planner.hpp"

namespace kinolab::rrt {

inline double millisecondsSince(std::chrono::steady_clock::time_point begin) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin)
      .count();
}

/// The last plan's graph of `planner` (states of a real vector space whose first three values
/// are the position), every edge a segment, decimated evenly to at most `max_edges`.
inline SearchTree plannerTree(const ompl::base::Planner& planner,
                              const ompl::base::SpaceInformationPtr& si, std::size_t max_edges) {
  ompl::base::PlannerData data(si);
  planner.getPlannerData(data);
  std::vector<std::pair<unsigned int, unsigned int>> edges;
  std::vector<unsigned int> children;
  for (unsigned int parent = 0; parent < data.numVertices(); ++parent) {
    data.getEdges(parent, children);
    for (const unsigned int child : children) edges.emplace_back(parent, child);
  }
  const auto position = [&data](unsigned int vertex) {
    const double* x = data.getVertex(vertex)
                          .getState()
                          ->as<ompl::base::RealVectorStateSpace::StateType>()
                          ->values;
    return Eigen::Vector3d(x[0], x[1], x[2]);
  };
  SearchTree tree;
  const std::size_t stride = treeStride(edges.size(), max_edges);
  for (std::size_t i = 0; i < edges.size(); i += stride) {
    SearchTreeEdge edge;
    edge.points = {position(edges[i].first), position(edges[i].second)};
    edge.state = SearchTreeEdge::State::kFull;
    edge.closed = true;
    tree.push_back(std::move(edge));
  }
  return tree;
}

}  // namespace kinolab::rrt
