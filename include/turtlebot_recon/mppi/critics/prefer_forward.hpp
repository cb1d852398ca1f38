// Prefer forward critic (Nav2's PreferForwardCritic): the lidar and the planner look ahead;
// backing up is for getting out of a tight spot, not for making progress.
//
//   cost_k = weight x mean_t max(-v_k,t, 0)   (m/s)
#pragma once

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct PreferForwardParams {
  double weight = 5.0;   // per m/s of mean reverse speed; 0 disables
};

class PreferForwardCritic : public Critic {
 public:
  explicit PreferForwardCritic(const PreferForwardParams& p) : p_(p) {}
  const char* name() const override { return "prefer_forward"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    if (p_.weight <= 0) return;
    const float scale = static_cast<float>(p_.weight / d.v.cols());
    costs += scale * (-d.v).max(0.0f).rowwise().sum();
  }

 private:
  PreferForwardParams p_;
};

}  // namespace turtlebot_recon::mppi
