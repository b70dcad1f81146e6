#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>

#include "flight_loop.hpp"
#include "flight_views.hpp"
#include "kinolab/core/text.hpp"

namespace kinolab::flight_motion {

namespace {

/// A plan that can be flown: a trajectory the checker passed, exact or approximate.
bool flyable(const PlanResult& plan) {
  return !plan.trajectory.empty() && plan.check.valid &&
         (plan.status == PlanStatus::kExact || plan.status == PlanStatus::kApproximate);
}

}  // namespace

bool FlightLoop::take(const PlanResult& plan, double t_start, const Eigen::Vector3d& goal,
                      const World& window, FlightReplan& replan) {
  if (settings_.timing == FlightTiming::kRealTime &&
      plan.planning_time_ms > 1000.0 * settings_.replanLatency()) {
    replan.status = "late";
    replan.why = "planning took " + formatNumber(plan.planning_time_ms) + " ms, past the " +
                 formatNumber(1000.0 * settings_.replanLatency()) + " ms latency";
    return false;
  }
  if (plan.status == PlanStatus::kExact && plan.trajectory.empty()) {
    replan.status = "at_local_goal";  // recover() moves onto it
    replan.why = "the start is already within the planner's goal region of the local goal";
    return false;
  }
  if (!flyable(plan)) {
    replan.why = !plan.trajectory.empty() && !plan.check.valid
                     ? "the checker: " + plan.check.check + ": " + plan.check.detail
                     : (plan.message.empty() ? "no trajectory" : plan.message);
    return false;
  }
  if (settings_.keep_faster && committed_free_ && committed_body_.radius >= planning_body_.radius &&
      arrivesFirst(committed_, plan.trajectory, t_start, goal, 0.5 * map_model_.resolution,
                   limits_.limits.bound[1].norm())) {
    replan.kept = true;
    replan.trajectory = plan.trajectory;
    replan.why = "the committed trajectory comes as near the local goal no later";
    return false;
  }
  const double vouched = committableFor(plan.trajectory, planning_body_);
  blocker_.reset();
  if (settings_.commit == CommitSpace::kSeen && vouched < plan.trajectory.duration()) {
    blocker_ = planBlocker(*map_, plan.trajectory, planning_body_, settings_.planning_margin);
  }
  std::optional<Cut> cut = latestCut(plan.trajectory, vouched, t_start, window, planning_body_);
  if (!cut) {
    replan.why = notCommittedWhy(settings_.commit, vouched);
    return false;
  }
  const ChainState here = stateAt(committed_, t_);
  if (settings_.step_back && atRest(here) && blocker_ &&
      (cut->spliced.endPosition() - here.col(0)).norm() < kStalled &&
      stepBack(here.col(0), *blocker_, window)) {
    // At rest, a plan that stops again within centimetres held the vehicle where it stood,
    // replan after replan: it steps back to see instead (else takes it).
    replan.why = "the plan commits less than " + formatNumber(kStalled) +
                 " m before it leaves the space the known map vouches for (commit: seen)";
    replan.recovery = "step_back";
    return false;
  }
  replan.trajectory = plan.trajectory;
  commit(plan.trajectory, t_start, std::move(*cut), planning_body_);
  return true;
}

std::optional<FlightLoop::Cut> FlightLoop::latestCut(const Trajectory& plan, double vouched,
                                                     double t_start, const World& window,
                                                     const Body& body) const {
  for (double at = std::min(plan.duration(), vouched); at > 0.0; at -= 0.1) {
    Trajectory spliced = splice(committed_, t_start, slice(plan, at), brake_rate_);
    if (committable(spliced, t_start, window, body)) return Cut{at, std::move(spliced)};
  }
  return std::nullopt;
}

void FlightLoop::commit(const Trajectory& plan, double t_start, Cut cut, const Body& body) {
  intended_ = splice(committed_, t_start, plan, brake_rate_);
  committed_ = std::move(cut.spliced);
  committed_body_ = body;
  backup_start_ = t_start + cut.at;
  backup_counted_ = false;
}

bool FlightLoop::committable(const Trajectory& trajectory, double from, const World& window,
                             const Body& body) const {
  if (settings_.commit == CommitSpace::kPlanned) {
    return freeFrom(trajectory, from, truth_->bounds(), window, body, limits_.limits);
  }
  return vouchedTrace(*map_, trajectory, from, body, body.radius - body_.radius).free;
}

double FlightLoop::committableFor(const Trajectory& plan, const Body& body) const {
  if (settings_.commit == CommitSpace::kPlanned) return plan.duration();
  return vouchedUntil(*map_, plan, body, body.radius - body_.radius);
}

double FlightLoop::heading(double t) const {
  if (look_yaw_) return *look_yaw_;
  return lookAlong(intended_, t, *map_, planning_body_, settings_.commit == CommitSpace::kSeen,
                   limits_.limits.bound[1].norm(), query_.goal);
}

void FlightLoop::recover(FlightReplan& replan, const std::shared_ptr<const World>& shared_window) {
  const World& window = *shared_window;
  ++failed_in_a_row_;
  if (!replan.recovery.empty()) return;  // take() stepped back
  const ChainState here = stateAt(committed_, t_);
  if (!atRest(here)) return;
  if (settings_.step_back && blocker_ && replan.status != "invalid_start" &&
      replan.status != "at_local_goal" && stepBack(here.col(0), *blocker_, window)) {
    replan.recovery = "step_back";
    return;
  }
  for (const BackOff& move : backOffMoves(replan.status, here.col(0), window, mapDomain(),
                                          planning_body_.radius, map_model_.resolution)) {
    if (moveStraight(here.col(0), move.offset, window, move.body_alone ? body_ : planning_body_)) {
      replan.recovery = "back_off";
      return;
    }
  }
  if (replan.status == "at_local_goal" && (replan.local_goal - here.col(0)).norm() > 0.05 &&
      moveStraight(here.col(0), replan.local_goal - here.col(0), window, planning_body_)) {
    replan.recovery = "approach";
    return;
  }
  if (replan.status == "no_solution" && escape(replan, shared_window)) {
    replan.recovery = "escape";
    return;
  }
  if (failed_in_a_row_ >= 2) {
    look_offset_ = std::fmod(look_offset_ + 90.0 * kDegree, 2.0 * M_PI);
    replan.recovery = "look";
  }
}

bool FlightLoop::escape(FlightReplan& replan, const std::shared_ptr<const World>& window) {
  if (!settings_.escape || !(settings_.escape_margin < settings_.planning_margin)) return false;
  const Body escape_body = body_.grown(settings_.escape_margin);
  const double t_start = t_ + settings_.replanLatency();  // at rest: the same state
  PlanningQuery local;
  local.start = stateAt(committed_, t_start);
  local.goal = replan.local_goal;
  // Slowing scales the start's velocity too: only from rest.
  if (local.start.col(1).norm() > 1e-6) return false;
  const PlanResult plan = planOn(window, settings_.escape_margin, local);
  replan.planning_time_ms += plan.planning_time_ms;
  if (!flyable(plan)) return false;
  Trajectory slowed = slowedTo(plan.trajectory, settings_.escape_speed);
  std::optional<Cut> cut =
      latestCut(slowed, committableFor(slowed, escape_body), t_start, *window, escape_body);
  if (!cut) return false;
  commit(slowed, t_start, std::move(*cut), escape_body);
  replan.trajectory = std::move(slowed);
  look_offset_ = 0.0;
  look_yaw_.reset();  // the camera looks along the escape
  next_replan_ = t_ + settings_.replan_period;
  return true;
}

bool FlightLoop::stepBack(const Eigen::Vector3d& position, const Eigen::Vector3d& blocker,
                          const World& window) {
  const double yaw = yawTowards(position, blocker);
  const bool facing = look_yaw_ && std::abs(std::remainder(*look_yaw_ - yaw, 2.0 * M_PI)) < 0.2;
  look_offset_ = 0.0;
  const double ahead = heading(t_);
  for (const StepBackMove& move :
       stepBackMoves(position, blocker, {std::cos(ahead), std::sin(ahead)}, tangents_,
                     planning_body_.radius, map_model_.resolution, kStepBack)) {
    if (moveStraight(position, move.offset, window, planning_body_)) {
      look_yaw_ = move.yaw;
      return true;
    }
  }
  look_yaw_ = yaw;
  return !facing;
}

bool FlightLoop::moveStraight(const Eigen::Vector3d& position, const Eigen::Vector3d& offset,
                              const World& window, const Body& body) {
  const auto move =
      straightMove(position, offset, 0.5 * brake_rate_, 0.5 * limits_.limits.bound[1].minCoeff());
  Trajectory moved = slice(committed_, t_);
  for (const TrajectorySegment& segment : move) moved.append(segment);
  if (!committable(moved, t_, window, body)) return false;
  committed_ = std::move(moved);
  committed_body_ = body;
  intended_ = committed_;
  backup_start_ = INFINITY;  // rest to rest: no back-up to fly
  next_replan_ = committed_.duration();
  return true;
}

}  // namespace kinolab::flight_motion
