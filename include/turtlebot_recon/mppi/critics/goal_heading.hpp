// Goal heading critic (Nav2's GoalAngleCritic, at a third of its weight: at 3 it holds a robot
// that must approach the goal sideways 0.2 m short of it): near the goal, the rollouts that
// face the goal's heading. The controller turns in place to the exact heading at the goal.
//
//   cost_k = weight x mean_t | wrap(yaw_k,t - goal_yaw) |   (rad)
//
// Only when the goal has a heading and the start is within `threshold_m` of the goal.
#pragma once

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct GoalHeadingParams {
  double weight = 1.0;        // per rad of mean heading error; 0 disables
  double threshold_m = 0.5;   // active within this distance of the goal
};

class GoalHeadingCritic : public Critic {
 public:
  explicit GoalHeadingCritic(const GoalHeadingParams& p) : p_(p) {}
  const char* name() const override { return "goal_heading"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    if (p_.weight <= 0 || !d.goal.has_yaw() || d.goal_distance_m > p_.threshold_m) return;
    const float scale = static_cast<float>(p_.weight / d.yaw.cols());
    costs += scale * angle_diff(d.yaw, static_cast<float>(d.goal.yaw)).abs().rowwise().sum();
  }

 private:
  GoalHeadingParams p_;
};

}  // namespace turtlebot_recon::mppi
