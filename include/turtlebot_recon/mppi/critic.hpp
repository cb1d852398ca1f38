// The critic contract of MPPI: each critic scores every rollout of a cycle and adds its cost
// to one cost per rollout. A critic reads only the cycle's shared data (CriticData, const
// references), holds its own parameters (one file per critic, include/.../mppi/critics/), and
// returns at once when its weight is 0 (disabled) or it does not apply this cycle.
//
// Costs are in "weight x unit of the critic" (m, rad, fraction); the softmax's temperature
// (optimizer.hpp) is on the same scale.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "turtlebot_recon/body_field.hpp"
#include "turtlebot_recon/mppi/clear_mask.hpp"
#include "turtlebot_recon/mppi/motion_model.hpp"
#include "turtlebot_recon/mppi/path_field.hpp"

namespace turtlebot_recon::mppi {

struct Goal {
  double x = 0.0, y = 0.0;  // m, map frame: the end of the global path
  double yaw = NAN;         // rad, NaN: any heading
  bool has_yaw() const { return std::isfinite(yaw); }
};

// One cycle's data, shared by every critic. Rollout arrays are [batch x T]: the poses after
// each step and the speeds (feasible: after the motion model's limits) of each step.
struct CriticData {
  const Array& x;
  const Array& y;
  const Array& yaw;
  const Array& cos_yaw;               // cos and sin of yaw
  const Array& sin_yaw;
  const Array& v;
  const Array& w;
  const Pose& start;                  // the robot (or nominal) pose now
  const Goal& goal;
  double goal_distance_m;             // from the start to the goal
  bool near_goal;                     // within the goal region: goal critics on, path ones off
  const PathField& path;              // the local path, from the point nearest the start
  const control::DistanceField& field;  // obstacles
  const ClearMask& clear;             // where the body is clear of them for sure (band included)
  const control::BodyOutline& body;
  const MotionLimits& limits;
  double dt_s;
  double reach_m;                     // max_linear_mps x horizon: how far a rollout can go
  double margin_m;                    // the body nearer an obstacle than this collides
  int threads;                        // for the per-rollout loops (parallel_for)
};

class Critic {
 public:
  virtual ~Critic() = default;
  virtual const char* name() const = 0;
  // Adds this critic's cost of every rollout to `costs` (size batch).
  virtual void score(const CriticData& data, Eigen::ArrayXf& costs) = 0;
};

// fn(k0, k1) over [0, n) in `threads` contiguous chunks, the first on the calling thread.
// Each rollout's cost is written by one chunk only: the result does not depend on `threads`.
template <class Fn>
inline void parallel_for(Eigen::Index n, int threads, Fn&& fn) {
  const Eigen::Index parts = std::clamp<Eigen::Index>(threads, 1, std::max<Eigen::Index>(n, 1));
  if (parts == 1) return fn(Eigen::Index{0}, n);
  std::vector<std::thread> pool;
  for (Eigen::Index p = 1; p < parts; ++p)
    pool.emplace_back(fn, n * p / parts, n * (p + 1) / parts);
  fn(Eigen::Index{0}, n / parts);
  for (auto& t : pool) t.join();
}

// The signed difference a - b of angles, wrapped to [-pi, pi), elementwise.
template <class Derived>
inline typename Derived::PlainObject angle_diff(const Eigen::ArrayBase<Derived>& a, float b) {
  constexpr float kPi = 3.14159265358979323846f, kTwoPi = 2.0f * kPi;
  typename Derived::PlainObject d = a.derived() - b;
  return d - kTwoPi * ((d + kPi) / kTwoPi).floor();
}

}  // namespace turtlebot_recon::mppi
