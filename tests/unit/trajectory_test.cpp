#include "kinolab/trajectory/trajectory.hpp"

#include <gtest/gtest.h>

#include "kinolab/core/error.hpp"
#include "kinolab/core/random.hpp"

namespace kinolab {
namespace {

TEST(Trajectory, PrimitiveSegmentsMatchTheIntegratorChain) {
  Rng rng(3);
  for (int order = 2; order <= 4; ++order) {
    const IntegratorChain chain(order);
    for (int trial = 0; trial < 50; ++trial) {
      ChainState start = ChainState::Zero();
      for (int k = 0; k < order; ++k) {
        for (int axis = 0; axis < 3; ++axis) start(axis, k) = rng.uniform(-2.0, 2.0);
      }
      const Eigen::Vector3d control(rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3));
      const auto segment = TrajectorySegment::primitive(start, control, order, 0.7);
      for (double t : {0.0, 0.2, 0.7}) {
        const ChainState expected = chain.stateAt(start, control, t);
        for (int k = 0; k < order; ++k) {
          EXPECT_LT((segment.evaluate(t, k) - expected.col(k)).norm(), 1e-12);
        }
        EXPECT_LT((segment.evaluate(t, order) - control).norm(), 1e-12);
        EXPECT_EQ(segment.evaluate(t, order + 1), Eigen::Vector3d::Zero());
      }
    }
  }
}

TEST(Trajectory, PiecesJoinAndGlobalTimeFindsTheRightPiece) {
  const IntegratorChain chain(2);
  ChainState state = ChainState::Zero();
  Trajectory trajectory;
  const std::vector<Eigen::Vector3d> controls = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0.5}};
  for (const auto& control : controls) {
    trajectory.append(TrajectorySegment::primitive(state, control, 2, 0.5));
    state = chain.stateAt(state, control, 0.5);
  }
  EXPECT_DOUBLE_EQ(trajectory.duration(), 1.5);
  EXPECT_LT((trajectory.endPosition() - state.col(0)).norm(), 1e-12);
  EXPECT_LT((trajectory.evaluate(1.5, 1) - state.col(1)).norm(), 1e-12);
  // At a joint the acceleration is the next piece's control.
  EXPECT_EQ(trajectory.evaluate(0.5, 2), controls[1]);
  EXPECT_EQ(trajectory.evaluate(0.49, 2), controls[0]);
  // Clamped outside [0, duration].
  EXPECT_EQ(trajectory.evaluate(-1.0), trajectory.startPosition());
  EXPECT_EQ(trajectory.evaluate(9.0), trajectory.endPosition());
}

TEST(Trajectory, JumpsAreFoundAtTheJointsOnly) {
  // Two acceleration primitives, the second starting where the first ended: position and
  // velocity continuous, the acceleration jumping from (1, 0, 0) to (0, -2, 0).
  Trajectory two;
  const TrajectorySegment first =
      TrajectorySegment::primitive(ChainState::Zero(), {1, 0, 0}, 2, 1.0);
  ChainState joint = ChainState::Zero();
  joint.col(0) = first.evaluate(1.0, 0);
  joint.col(1) = first.evaluate(1.0, 1);
  two.append(first);
  two.append(TrajectorySegment::primitive(joint, {0, -2, 0}, 2, 1.0));
  EXPECT_EQ(two.jumps(0).count, 0);
  EXPECT_EQ(two.jumps(1).count, 0);
  const Trajectory::Jumps acceleration = two.jumps(2);
  EXPECT_EQ(acceleration.count, 1);
  EXPECT_NEAR(acceleration.squared_sum, 1.0 + 4.0, 1e-12);
  EXPECT_NEAR(two.squaredIntegral(2), 1.0 + 4.0, 1e-12);  // |a|^2 for 1 s each
}

TEST(Trajectory, LengthJerkAndSamplesByHand) {
  // x(t) = t^3 over [0, 2]: jerk 6, |jerk|^2 integral 36 * 2; length 8.
  Trajectory cubic;
  TrajectorySegment segment;
  segment.duration = 2.0;
  segment.coefficients = Eigen::Matrix<double, 3, 4>::Zero();
  segment.coefficients(0, 3) = 1.0;
  cubic.append(segment);
  EXPECT_NEAR(cubic.squaredIntegral(3), 72.0, 1e-9);
  EXPECT_NEAR(cubic.squaredIntegral(2), 6.0 * 6.0 * 8.0 / 3.0, 1e-9);  // a = 6t: 36 t^3 / 3
  EXPECT_NEAR(cubic.length(), 8.0, 1e-9);
  // A quadratic (acceleration control) has no jerk inside its pieces.
  Trajectory quadratic;
  quadratic.append(TrajectorySegment::primitive(ChainState::Zero(), {1, 2, 2}, 2, 1.0));
  EXPECT_EQ(quadratic.squaredIntegral(3), 0.0);
  EXPECT_NEAR(quadratic.length(), 1.5, 1e-9);  // |a| t^2 / 2 with |a| = 3

  const auto samples = cubic.sample(0.3);
  ASSERT_EQ(samples.size(), 8u);  // 0, 0.3, ..., 1.8, and the end 2.0
  EXPECT_DOUBLE_EQ(samples.back().time, 2.0);
  EXPECT_NEAR(samples[1].position.x(), 0.027, 1e-12);
  EXPECT_NEAR(samples[1].velocity.x(), 0.27, 1e-12);
  EXPECT_NEAR(samples[1].acceleration.x(), 1.8, 1e-12);
  EXPECT_NEAR(samples[1].jerk.x(), 6.0, 1e-12);
  EXPECT_NEAR(cubic.closestDistance({8.0, 1.0, 0.0}, 0.01), 1.0, 1e-9);
}

TEST(Trajectory, RejectsEmptyPiecesAndEvaluation) {
  Trajectory trajectory;
  EXPECT_THROW(trajectory.evaluate(0.0), InvalidArgument);
  EXPECT_THROW(trajectory.append(TrajectorySegment{}), InvalidArgument);
  EXPECT_TRUE(trajectory.sample(0.1).empty());
}

}  // namespace
}  // namespace kinolab
