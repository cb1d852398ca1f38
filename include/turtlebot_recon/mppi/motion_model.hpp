// MPPI's motion model: a differential drive (unicycle) with the robot's velocity and
// acceleration limits (seed 000's lesson: a model that ignores them plans commands the robot
// cannot follow, and drives jerkily).
//
// Rollouts are Eigen arrays [batch x time], column-major: column t holds step t of every
// rollout, so each step below is one vector operation over the batch.
//
//   limits    v_t = clamp(v*_t, v_{t-1} - a_v dt, v_{t-1} + a_v dt) within [v_min, v_max],
//             the same for w with a_w and [-w_max, w_max]; v_{-1}, w_{-1}: the speeds now.
//   poses     seed 000's discrete unicycle (Euler):
//             x_{t+1} = x_t + dt v_t cos(yaw_t), y_{t+1} = y_t + dt v_t sin(yaw_t),
//             yaw_{t+1} = yaw_t + dt w_t.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace turtlebot_recon::mppi {

// [batch x time] of one quantity; a column is one time step of every rollout.
using Array = Eigen::Array<float, Eigen::Dynamic, Eigen::Dynamic>;

struct Pose {
  double x = 0.0, y = 0.0, yaw = 0.0;  // m, m, rad (map frame)
};

struct Speeds {
  double v = 0.0, w = 0.0;  // m/s, rad/s (robot frame)
};

struct MotionLimits {
  // < 0 allows reversing; no default here: the caller's (config/mppi.yaml), NaN until set
  double min_linear_mps = std::numeric_limits<double>::quiet_NaN();
  double max_linear_mps = 0.26;
  double max_angular_radps = 1.82;      // symmetric: [-max, max]
  double max_linear_accel_mps2 = 2.5;
  double max_angular_accel_radps2 = 3.2;
  bool clamp_velocity = true;           // false: only accelerations are limited (the
                                        // velocity_limits critic then prices the excess)

  void validate() const {
    if (std::isnan(min_linear_mps))
      throw std::invalid_argument("MotionLimits: min_linear_mps is not set (config/mppi.yaml)");
    if (!(max_linear_mps > 0 && min_linear_mps <= 0 && max_angular_radps > 0 &&
          max_linear_accel_mps2 > 0 && max_angular_accel_radps2 > 0))
      throw std::invalid_argument(
          "MotionLimits: need max_linear_mps > 0 >= min_linear_mps and positive angular and "
          "acceleration limits");
  }
};

class DiffDriveModel {
 public:
  DiffDriveModel() = default;
  DiffDriveModel(const MotionLimits& limits, double dt_s) : limits_(limits), dt_(dt_s) {
    limits_.validate();
    if (!(dt_s > 0)) throw std::invalid_argument("DiffDriveModel: dt must be > 0 s");
  }

  double dt() const { return dt_; }
  const MotionLimits& limits() const { return limits_; }

  // The requested speeds (v, w) [batch x T] made feasible in place, step by step from `now`.
  void constrain(Array& v, Array& w, const Speeds& now) const {
    const float dv = static_cast<float>(limits_.max_linear_accel_mps2 * dt_);
    const float dw = static_cast<float>(limits_.max_angular_accel_radps2 * dt_);
    const float v_lo = static_cast<float>(limits_.min_linear_mps);
    const float v_hi = static_cast<float>(limits_.max_linear_mps);
    const float w_hi = static_cast<float>(limits_.max_angular_radps);
    const auto n = v.rows();
    Eigen::ArrayXf v_prev = Eigen::ArrayXf::Constant(n, static_cast<float>(now.v));
    Eigen::ArrayXf w_prev = Eigen::ArrayXf::Constant(n, static_cast<float>(now.w));
    for (Eigen::Index t = 0; t < v.cols(); ++t) {
      auto vt = v.col(t);
      auto wt = w.col(t);
      vt = vt.min(v_prev + dv).max(v_prev - dv);
      wt = wt.min(w_prev + dw).max(w_prev - dw);
      if (limits_.clamp_velocity) {
        vt = vt.min(v_hi).max(v_lo);
        wt = wt.min(w_hi).max(-w_hi);
      }
      v_prev = vt;
      w_prev = wt;
    }
  }

  // The poses after each step [batch x T] from `start` under the speeds (v, w), with the
  // cosine and sine of their yaws (computed once here, vectorised, for the integration and
  // for the critics that place the body).
  void integrate(const Array& v, const Array& w, const Pose& start, Array& x, Array& y,
                 Array& yaw, Array& cos_yaw, Array& sin_yaw) const {
    const auto n = v.rows(), T = v.cols();
    x.resize(n, T);
    y.resize(n, T);
    yaw.resize(n, T);
    const float dt = static_cast<float>(dt_);
    yaw.col(0) = static_cast<float>(start.yaw) + dt * w.col(0);
    for (Eigen::Index t = 1; t < T; ++t) yaw.col(t) = yaw.col(t - 1) + dt * w.col(t);
    cos_yaw = yaw.cos();  // the whole array at once: vectorised over batch and time
    sin_yaw = yaw.sin();
    // step t moves along the yaw the step starts from: the start's, then pose t - 1's
    const float c0 = static_cast<float>(std::cos(start.yaw));
    const float s0 = static_cast<float>(std::sin(start.yaw));
    x.col(0) = static_cast<float>(start.x) + (dt * c0) * v.col(0);
    y.col(0) = static_cast<float>(start.y) + (dt * s0) * v.col(0);
    for (Eigen::Index t = 1; t < T; ++t) {
      x.col(t) = x.col(t - 1) + dt * v.col(t) * cos_yaw.col(t - 1);
      y.col(t) = y.col(t - 1) + dt * v.col(t) * sin_yaw.col(t - 1);
    }
  }

 private:
  MotionLimits limits_;
  double dt_ = 0.05;
};

}  // namespace turtlebot_recon::mppi
