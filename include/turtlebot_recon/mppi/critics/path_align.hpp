// Path align critic (Nav2's PathAlignCritic): stay on the path, where the planner checked the
// body fits; cutting a corner would bring the box near the walls the plan kept away from.
//
//   cost_k = weight x mean_t dist(p_k,t, path)   (m; PathField's distance grid)
//
// over every kStep-th pose (Nav2's trajectory_point_step): 4 x 0.05 s apart, 5 cm at 0.26 m/s,
// a quarter of the lookups for the same mean.
//
// Off near the goal (CriticData::near_goal): the goal critics take over. Off too while the
// body does not fit on the path within the reach (a new obstacle on it, Nav2's
// max_path_occupancy_ratio at 0): the path is wrong there until the next plan, and pulling
// the rollouts onto it would hold them against the obstacle instead of around it.
#pragma once

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct PathAlignParams {
  double weight = 14.0;         // per m of mean distance from the path; 0 disables
};

class PathAlignCritic : public Critic {
 public:
  explicit PathAlignCritic(const PathAlignParams& p) : p_(p) {}
  const char* name() const override { return "path_align"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    if (p_.weight <= 0 || d.near_goal || !path_fits(d)) return;
    const Eigen::Index n = d.x.rows(), T = d.x.cols();
    const Eigen::Index used = (T - 1) / kStep + 1;
    const float scale = static_cast<float>(p_.weight / used);
    parallel_for(n, d.threads, [&](Eigen::Index k0, Eigen::Index k1) {
      for (Eigen::Index t = (T - 1) % kStep; t < T; t += kStep) {  // ends on the last pose
        const float* xs = d.x.col(t).data();
        const float* ys = d.y.col(t).data();
        for (Eigen::Index k = k0; k < k1; ++k) costs[k] += scale * d.path.distance(xs[k], ys[k]);
      }
    });
  }

 private:
  // Whether the body, heading along the path, keeps `margin` at every path point within the
  // reach (the local path starts at the robot's progress).
  static bool path_fits(const CriticData& d) {
    const int n = d.path.size();
    double s = 0.0;
    for (int i = 1; i < n && s <= d.reach_m; ++i) {
      const double dx = d.path.x(i) - d.path.x(i - 1), dy = d.path.y(i) - d.path.y(i - 1);
      s += std::hypot(dx, dy);
      if (dx == 0 && dy == 0) continue;
      const double c = control::body_clearance(d.field, d.body, d.path.x(i), d.path.y(i),
                                               std::atan2(dy, dx), d.margin_m);
      if (c < d.margin_m) return false;
    }
    return true;
  }

  static constexpr Eigen::Index kStep = 4;
  PathAlignParams p_;
};

}  // namespace turtlebot_recon::mppi
