// Goal distance critic (Nav2's GoalCritic): near the goal, the rollouts that stay close to it.
//
//   cost_k = weight x mean_t || p_k,t - goal ||   (m)
//
// Only near the goal (CriticData::near_goal); farther out the path critics lead the way
// (and this one would cut the path's corners toward the goal).
#pragma once

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct GoalDistanceParams {
  double weight = 5.0;        // per m of mean distance; 0 disables
};

class GoalDistanceCritic : public Critic {
 public:
  explicit GoalDistanceCritic(const GoalDistanceParams& p) : p_(p) {}
  const char* name() const override { return "goal_distance"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    if (p_.weight <= 0 || !d.near_goal) return;
    const float gx = static_cast<float>(d.goal.x), gy = static_cast<float>(d.goal.y);
    const float scale = static_cast<float>(p_.weight / d.x.cols());
    costs += scale * ((d.x - gx).square() + (d.y - gy).square()).sqrt().rowwise().sum();
  }

 private:
  GoalDistanceParams p_;
};

}  // namespace turtlebot_recon::mppi
