#include "kinolab/flight/tracking.hpp"

#include <algorithm>
#include <cmath>

namespace kinolab {

QuadrotorTracker::QuadrotorTracker(const TrackingModel& model, const Eigen::Vector3d& start,
                                   std::uint64_t seed)
    : model_(model), wind_rng_(Rng::derive(seed, "wind")) {
  state_.col(0) = start;
}

Eigen::Vector3d QuadrotorTracker::feasible(const Eigen::Vector3d& command) const {
  // Vertical thrust first (as flight stacks prioritise it), then what the tilt and the
  // total thrust leave for the horizontal.
  const double most = model_.thrust_to_weight * kGravity;
  Eigen::Vector3d thrust = command + Eigen::Vector3d(0.0, 0.0, kGravity);
  thrust.z() = std::clamp(thrust.z(), 0.0, most);
  const double horizontal = thrust.head<2>().norm();
  const double allowed = std::min(thrust.z() * std::tan(model_.max_tilt),
                                  std::sqrt(std::max(0.0, most * most - thrust.z() * thrust.z())));
  if (horizontal > allowed) thrust.head<2>() *= allowed / horizontal;
  return thrust - Eigen::Vector3d(0.0, 0.0, kGravity);
}

Eigen::Vector3d QuadrotorTracker::turned(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                                         double angle) {
  const double length = to.norm();
  if (from.norm() < 1e-9 || length < 1e-9) return to;
  const Eigen::Vector3d u = from.normalized();
  const Eigen::Vector3d w = to / length;
  const Eigen::Vector3d across = w - u.dot(w) * u;
  // Within the angle, or straight back (no plane to turn in: never, thrust never pulls down).
  if (std::atan2(across.norm(), u.dot(w)) <= angle || across.norm() < 1e-12) return to;
  return length * (std::cos(angle) * u + std::sin(angle) * across.normalized());
}

void QuadrotorTracker::advance(const Trajectory& reference, double t) {
  const double period = 1.0 / model_.control_rate;
  // A remainder under a nanosecond is no step (its wind's jerk would be unbounded).
  while (t - time_ > 1e-9) {
    const double h = std::min(period, t - time_);
    // Past its end the reference rests where it ended.
    const bool after = time_ >= reference.duration();
    const double at = std::clamp(time_, 0.0, reference.duration());
    // The feed-forward reads the reference previewTime() ahead (at rest past its end).
    const double ahead = time_ + model_.previewTime();
    const Eigen::Vector3d feed_forward =
        ahead >= reference.duration() ? Eigen::Vector3d::Zero() : reference.evaluate(ahead, 2);
    Eigen::Vector3d position_error = reference.evaluate(at, 0) - state_.col(0);
    if (position_error.norm() > model_.max_position_error) {
      position_error *= model_.max_position_error / position_error.norm();
    }
    const Eigen::Vector3d command = feasible(
        feed_forward + model_.position_gain * position_error +
        model_.velocity_gain *
            ((after ? Eigen::Vector3d::Zero() : reference.evaluate(at, 1)) - state_.col(1)));
    // The attitude's lag; the thrust vector's direction turns at most max_body_rate (the
    // vehicle's rotation), its length (the motors' collective thrust) follows with the lag.
    const Eigen::Vector3d up(0.0, 0.0, kGravity);
    const Eigen::Vector3d turn =
        (turned(thrust_ + up,
                thrust_ + up + (command - thrust_) * (h / std::max(model_.attitude_time, h)),
                model_.max_body_rate * h) -
         (thrust_ + up)) /
        h;
    // The wind: an Ornstein-Uhlenbeck step per axis, stationary deviation wind_sigma; linear
    // within the step, so that the acceleration stays continuous.
    Eigen::Vector3d wind = wind_;
    if (model_.wind_sigma > 0.0) {
      const double decay = std::exp(-h / model_.wind_time);
      const double spread = model_.wind_sigma * std::sqrt(1.0 - decay * decay);
      for (int axis = 0; axis < 3; ++axis) {
        wind[axis] = decay * wind_[axis] + spread * wind_rng_.normal();
      }
    }
    const Eigen::Vector3d jerk = turn + (wind - wind_) / h;
    const TrajectorySegment step = TrajectorySegment::primitive(state_, jerk, 3, h);
    flown_.append(step);
    for (int k = 0; k < 3; ++k) state_.col(k) = step.evaluate(h, k);
    state_.col(3) = jerk;
    thrust_ += turn * h;
    wind_ = wind;
    time_ += h;
  }
  time_ = std::max(time_, t);
}

}  // namespace kinolab
