// Velocity limits critic (Nav2's ConstraintCritic): the speeds a rollout drives beyond the
// robot's limits.
//
//   cost_k = weight x mean_t ( max(v - v_max, 0) + max(v_min - v, 0) + max(|w| - w_max, 0) )
//
// With MotionLimits::clamp_velocity (the default) the model never exceeds the limits and this
// costs nothing; without it (the model limits only accelerations, as a soft-constrained MPPI)
// it is what keeps the chosen speeds within them. The command is clamped either way.
#pragma once

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct VelocityLimitsParams {
  double weight = 10.0;   // per m/s (or rad/s) of mean excess; 0 disables
};

class VelocityLimitsCritic : public Critic {
 public:
  explicit VelocityLimitsCritic(const VelocityLimitsParams& p) : p_(p) {}
  const char* name() const override { return "velocity_limits"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    if (p_.weight <= 0 || d.limits.clamp_velocity) return;
    const float v_hi = static_cast<float>(d.limits.max_linear_mps);
    const float v_lo = static_cast<float>(d.limits.min_linear_mps);
    const float w_hi = static_cast<float>(d.limits.max_angular_radps);
    const float scale = static_cast<float>(p_.weight / d.v.cols());
    costs += scale * ((d.v - v_hi).max(0.0f) + (v_lo - d.v).max(0.0f) +
                      (d.w.abs() - w_hi).max(0.0f)).rowwise().sum();
  }

 private:
  VelocityLimitsParams p_;
};

}  // namespace turtlebot_recon::mppi
