// Path follow critic (Nav2's PathFollowCritic): progress along the path. The rollouts whose
// last pose ends nearest to a point one full reach ahead on the path (or the path's end):
//
//   cost_k = weight x || p_k,T - path(s_target) ||,   s_target = min(reach, path length)  (m)
//
// The local path starts at the path point nearest the start pose, so s is measured from the
// robot's progress. Off near the goal (CriticData::near_goal): the goal critics take over.
#pragma once

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct PathFollowParams {
  double weight = 5.0;          // per m from the end pose to the target point; 0 disables
};

class PathFollowCritic : public Critic {
 public:
  explicit PathFollowCritic(const PathFollowParams& p) : p_(p) {}
  const char* name() const override { return "path_follow"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    if (p_.weight <= 0 || d.near_goal) return;
    double tx, ty;
    d.path.point_at(d.reach_m, tx, ty);
    const auto last = d.x.cols() - 1;
    costs += static_cast<float>(p_.weight) *
             ((d.x.col(last) - static_cast<float>(tx)).square() +
              (d.y.col(last) - static_cast<float>(ty)).square()).sqrt();
  }

 private:
  PathFollowParams p_;
};

}  // namespace turtlebot_recon::mppi
