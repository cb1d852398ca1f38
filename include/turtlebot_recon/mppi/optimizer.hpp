// MPPI (seed 000's Algorithm 1; Williams et al.), in Nav2's shape: the loop below owns the
// buffers and calls the motion model, the noise generator and the critics, each kept apart.
//
// One iteration, optimize():
//   1. shift        warm start: the last control sequence U, advanced by the time since then
//   2. sample       K noised sequences u_k = U + eps_k (rollout 0: U itself, rollout 1: stop),
//                   made feasible by the motion model (velocity and acceleration limits)
//   3. rollout      the poses of every sequence from the start state [K x T]
//   4. score        C_k = sum of the critics' costs
//   5. weights      w_k = exp(-(C_k - min C) / lambda) / eta,  eta = sum_k exp(...)
//   6. update       U = sum_k w_k (U + eps_k)  (Algorithm 1, line 14), within the velocity
//                   limits: averaging the limited speeds instead would bias U below v_max
//                   (half the samples about U = v_max are cut there) and the robot would never
//                   reach its top speed
//   7. smooth       Savitzky-Golay (window 9, quadratic) over U, led by the sent commands
//   8. trajectory   U made feasible (accelerations from the speeds now) and rolled out: the
//                   chosen trajectory; U keeps that feasible form for the warm start
// The [K x T] buffers are allocated once (reset()); an iteration allocates only a few
// vectors of T or of the local path's size.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <vector>

#include "turtlebot_recon/body_field.hpp"
#include "turtlebot_recon/mppi/clear_mask.hpp"
#include "turtlebot_recon/mppi/critic.hpp"
#include "turtlebot_recon/mppi/critics/goal_distance.hpp"
#include "turtlebot_recon/mppi/critics/goal_heading.hpp"
#include "turtlebot_recon/mppi/critics/obstacle.hpp"
#include "turtlebot_recon/mppi/critics/path_align.hpp"
#include "turtlebot_recon/mppi/critics/path_follow.hpp"
#include "turtlebot_recon/mppi/critics/prefer_forward.hpp"
#include "turtlebot_recon/mppi/critics/velocity_limits.hpp"
#include "turtlebot_recon/mppi/motion_model.hpp"
#include "turtlebot_recon/mppi/noise_generator.hpp"
#include "turtlebot_recon/mppi/path_field.hpp"

namespace turtlebot_recon::mppi {

struct OptimizerSettings {
  int batch_size = 2000;            // K rollouts per iteration (Nav2: 2000)
  int time_steps = 56;              // T steps of model_dt_s (Nav2: 56 x 0.05 s = 2.8 s)
  double model_dt_s = 0.05;         // s
  double temperature = 0.3;         // lambda, in cost units (Nav2: 0.3)
  double noise_std_v_mps = 0.2;     // m/s (Nav2 vx_std: 0.2)
  double noise_std_w_radps = 0.4;   // rad/s (Nav2 wz_std: 0.4)
  int noise_knot_steps = 4;         // noise drawn every this many steps, linear between (1: white)
  double goal_region_m = 1.0;       // within it: goal critics on, path critics off (m)
  bool smooth = true;               // Savitzky-Golay over the control sequence
  double outline_spacing_m = 0.05;  // the box's outline points for the obstacle critic (m)
  double path_resolution_m = 0.05;  // the path critics' distance grid (m)
  int threads = 1;                  // threads of the obstacle and path_align critics (1: one core)
  std::uint32_t seed = 0;           // the noise's seed (reset() starts it again)
};

// Every parameter of the optimizer and its critics.
struct MppiConfig {
  OptimizerSettings optimizer;
  MotionLimits limits;
  GoalDistanceParams goal_distance;
  GoalHeadingParams goal_heading;
  PathFollowParams path_follow;
  PathAlignParams path_align;
  ObstacleParams obstacle;
  VelocityLimitsParams velocity_limits;
  PreferForwardParams prefer_forward;
};

// One iteration's answer.
struct Plan {
  Eigen::MatrixX2d controls;   // [T x 2] (v m/s, w rad/s): the control sequence U
  Eigen::MatrixX3d states;     // [T + 1 x 3] (x, y, yaw) from the start under U
  double min_cost = 0.0;       // the best rollout's cost
  int colliding = 0;           // rollouts that collided (or left the map)
  bool all_collide = false;    // every rollout did
  bool collides = false;       // the chosen trajectory does (the distance field's test)
};

class Optimizer {
 public:
  Optimizer(const MppiConfig& config, const planning::Footprint& footprint)
      : cfg_(config),
        model_(config.limits, config.optimizer.model_dt_s),
        body_(control::outline_body(footprint, config.optimizer.outline_spacing_m)) {
    const OptimizerSettings& s = cfg_.optimizer;
    if (s.batch_size < 2 || s.time_steps < 2)
      throw std::invalid_argument("Optimizer: batch_size and time_steps must be >= 2");
    if (!(s.temperature > 0)) throw std::invalid_argument("Optimizer: temperature must be > 0");
    if (!(s.path_resolution_m > 0))
      throw std::invalid_argument("Optimizer: path_resolution_m must be > 0");
    if (s.threads < 1) throw std::invalid_argument("Optimizer: threads must be >= 1");
    critics_.push_back(std::make_unique<GoalDistanceCritic>(cfg_.goal_distance));
    critics_.push_back(std::make_unique<GoalHeadingCritic>(cfg_.goal_heading));
    critics_.push_back(std::make_unique<PathFollowCritic>(cfg_.path_follow));
    critics_.push_back(std::make_unique<PathAlignCritic>(cfg_.path_align));
    auto obstacle = std::make_unique<ObstacleCritic>(cfg_.obstacle);
    obstacle_ = obstacle.get();
    critics_.push_back(std::move(obstacle));
    critics_.push_back(std::make_unique<VelocityLimitsCritic>(cfg_.velocity_limits));
    critics_.push_back(std::make_unique<PreferForwardCritic>(cfg_.prefer_forward));
    reset();
  }

  const MppiConfig& config() const { return cfg_; }
  const control::BodyOutline& body() const { return body_; }

  // Forget the control sequence and the sent commands; the noise starts again from the seed.
  void reset() {
    const int K = cfg_.optimizer.batch_size, T = cfg_.optimizer.time_steps;
    noise_ = NoiseGenerator(cfg_.optimizer.noise_std_v_mps, cfg_.optimizer.noise_std_w_radps,
                            cfg_.optimizer.noise_knot_steps, cfg_.optimizer.seed);
    u_v_ = Eigen::ArrayXf::Zero(T);
    u_w_ = Eigen::ArrayXf::Zero(T);
    history_v_.fill(0.0f);
    history_w_.fill(0.0f);
    for (Array* a : {&eps_v_, &eps_w_, &v_req_, &w_req_, &v_, &w_, &x_, &y_, &yaw_, &cos_, &sin_})
      a->resize(K, T);
    costs_.resize(K);
    weights_.resize(K);
  }

  // The control sequence and the sent commands held at (v, w), as if the robot had been
  // driving at them: after a reset for a new goal taken over while driving, the warm start
  // carries the speed on instead of starting from rest (from rest: the same as reset()).
  void carry(float v, float w) {
    u_v_.setConstant(v);
    u_w_.setConstant(w);
    history_v_.fill(v);
    history_w_.fill(w);
  }

  // The obstacles: the distance field of an occupancy grid whose cell (0, 0) has its corner
  // at the origin (m), and where the body is clear of them for sure.
  void set_map(control::DistanceField field, double origin_x_m, double origin_y_m) {
    field_ = std::move(field);
    clear_ = ClearMask(*field_, origin_x_m, origin_y_m, body_.radius_m,
                       std::max(cfg_.obstacle.band_m, cfg_.obstacle.margin_m));
  }
  bool has_map() const { return field_.has_value(); }
  const control::DistanceField& field() const { return *field_; }

  // How far a rollout can go (m): the fastest speed for the whole horizon.
  double reach_m() const {
    const auto& l = cfg_.limits;
    return std::max(l.max_linear_mps, -l.min_linear_mps) * cfg_.optimizer.time_steps *
           cfg_.optimizer.model_dt_s;
  }

  // One MPPI iteration from `start` moving at `now`, toward `goal` along the local `path`
  // (n >= 1 (x, y) points, row-major, from the path point nearest the start), after
  // `shift_steps` model steps since the last one.
  Plan optimize(const Pose& start, const Speeds& now, const double* path, int n,
                const Goal& goal, int shift_steps) {
    if (!field_) throw std::invalid_argument("Optimizer: no map (set_map first)");
    shift(shift_steps);
    path_.build(path, n, cfg_.optimizer.path_resolution_m, reach_m() + body_.radius_m + 0.5);
    sample_controls(now);
    model_.integrate(v_, w_, start, x_, y_, yaw_, cos_, sin_);
    score(start, goal);
    update_control_sequence();
    if (cfg_.optimizer.smooth) smooth();
    return chosen(start, now);
  }

  // Rollout k's poses [T x 3] of the last iteration (for rviz).
  Eigen::MatrixX3d rollout(int k) const {
    const int T = static_cast<int>(x_.cols());
    Eigen::MatrixX3d out(T, 3);
    out.col(0) = x_.row(k).transpose().cast<double>();
    out.col(1) = y_.row(k).transpose().cast<double>();
    out.col(2) = yaw_.row(k).transpose().cast<double>();
    return out;
  }
  int batch_size() const { return static_cast<int>(x_.rows()); }
  const Eigen::ArrayXf& costs() const { return costs_; }

 private:
  // 1. Warm start: drop the steps that have passed; the last control holds.
  void shift(int steps) {
    const Eigen::Index T = u_v_.size();
    const Eigen::Index s = std::clamp<Eigen::Index>(steps, 0, T - 1);
    if (s == 0) return;
    u_v_.head(T - s) = u_v_.tail(T - s).eval();
    u_w_.head(T - s) = u_w_.tail(T - s).eval();
    u_v_.tail(s).setConstant(u_v_[T - s - 1]);
    u_w_.tail(s).setConstant(u_w_[T - s - 1]);
  }

  // 2. u_k = U + eps_k, feasible. Rollout 0 keeps U as it is (the warm start competes
  // unchanged), rollout 1 asks to stop (a way out is always scored).
  void sample_controls(const Speeds& now) {
    noise_.sample(eps_v_, eps_w_);
    v_req_ = eps_v_.rowwise() + u_v_.transpose();
    w_req_ = eps_w_.rowwise() + u_w_.transpose();
    v_req_.row(0) = u_v_.transpose();
    w_req_.row(0) = u_w_.transpose();
    v_req_.row(1).setZero();
    w_req_.row(1).setZero();
    v_ = v_req_;
    w_ = w_req_;
    model_.constrain(v_, w_, now);
  }

  // 4. C_k: the sum of the critics' costs.
  void score(const Pose& start, const Goal& goal) {
    costs_.setZero();
    const double goal_distance = std::hypot(goal.x - start.x, goal.y - start.y);
    // In the goal region by the path left as well as by the straight line: a goal around a
    // corner 0.85 m away, with the path critics resting, held the robot against the corner.
    // The local path ends at the goal when that is near (else it is longer than the region).
    const double path_left =
        std::hypot(path_.x(0) - start.x, path_.y(0) - start.y) + path_.length();
    const bool near_goal = std::max(goal_distance, path_left) <= cfg_.optimizer.goal_region_m;
    const CriticData data{x_, y_, yaw_, cos_, sin_, v_, w_, start, goal, goal_distance, near_goal,
                          path_, *field_, clear_, body_,
                          cfg_.limits, cfg_.optimizer.model_dt_s, reach_m(),
                          cfg_.obstacle.margin_m, cfg_.optimizer.threads};
    for (auto& critic : critics_) critic->score(data, costs_);
  }

  // 5-6. Softmax weights with temperature lambda; U = the weighted mean of the sampled u_k,
  // within the velocity limits.
  void update_control_sequence() {
    const float lambda = static_cast<float>(cfg_.optimizer.temperature);
    weights_ = (-(costs_ - costs_.minCoeff()) / lambda).exp();
    weights_ /= weights_.sum();
    const MotionLimits& l = cfg_.limits;
    const float w_hi = static_cast<float>(l.max_angular_radps);
    u_v_ = (v_req_.matrix().transpose() * weights_.matrix()).array()
               .min(static_cast<float>(l.max_linear_mps)).max(static_cast<float>(l.min_linear_mps));
    u_w_ = (w_req_.matrix().transpose() * weights_.matrix()).array().min(w_hi).max(-w_hi);
  }

  // 7. Savitzky-Golay smoothing (window 9, quadratic fit: coefficients / 231); before U the
  // last commands sent, after it its last control repeated.
  void smooth() {
    static constexpr std::array<float, 9> kCoeff = {-21, 14, 39, 54, 59, 54, 39, 14, -21};
    const Eigen::Index T = u_v_.size();
    auto filter = [&](Eigen::ArrayXf& u, const std::array<float, 4>& history) {
      Eigen::ArrayXf padded(T + 8);
      for (int i = 0; i < 4; ++i) padded[i] = history[i];
      padded.segment(4, T) = u;
      padded.tail(4).setConstant(u[T - 1]);
      for (Eigen::Index t = 0; t < T; ++t) {
        float acc = 0.0f;
        for (int j = 0; j < 9; ++j) acc += kCoeff[j] * padded[t + j];
        u[t] = acc / 231.0f;
      }
    };
    filter(u_v_, history_v_);
    filter(u_w_, history_w_);
  }

  // 8. U feasible from the speeds now, its trajectory, and the command sent (U[0]) recorded.
  Plan chosen(const Pose& start, const Speeds& now) {
    const Eigen::Index T = u_v_.size();
    Array v = u_v_.transpose(), w = u_w_.transpose();  // [1 x T]
    model_.constrain(v, w, now);
    u_v_ = v.row(0).transpose();
    u_w_ = w.row(0).transpose();
    Array x, y, yaw, cos_yaw, sin_yaw;
    model_.integrate(v, w, start, x, y, yaw, cos_yaw, sin_yaw);
    Plan plan;
    plan.controls.resize(T, 2);
    plan.controls.col(0) = u_v_.cast<double>().matrix();
    plan.controls.col(1) = u_w_.cast<double>().matrix();
    plan.states.resize(T + 1, 3);
    plan.states.row(0) << start.x, start.y, start.yaw;
    plan.states.block(1, 0, T, 1) = x.row(0).transpose().cast<double>().matrix();
    plan.states.block(1, 1, T, 1) = y.row(0).transpose().cast<double>().matrix();
    plan.states.block(1, 2, T, 1) = yaw.row(0).transpose().cast<double>().matrix();
    plan.min_cost = costs_.minCoeff();
    for (Eigen::Index k = 0; k < costs_.size(); ++k) plan.colliding += obstacle_->collided(k);
    plan.all_collide = plan.colliding == costs_.size();
    const double margin = cfg_.obstacle.margin_m;
    const double start_clearance = control::body_clearance(*field_, body_, start.x, start.y,
                                                           start.yaw, margin);
    for (Eigen::Index t = 1; t <= T && !plan.collides; ++t) {
      const auto p = plan.states.row(t);
      const double c = field_->contains(p(0), p(1))
          ? control::body_clearance(*field_, body_, p(0), p(1), p(2), margin) : -1.0;
      plan.collides = c < std::min(margin, start_clearance - 1e-3);
    }
    std::rotate(history_v_.begin(), history_v_.begin() + 1, history_v_.end());
    std::rotate(history_w_.begin(), history_w_.begin() + 1, history_w_.end());
    history_v_.back() = u_v_[0];
    history_w_.back() = u_w_[0];
    return plan;
  }

  MppiConfig cfg_;
  DiffDriveModel model_;
  control::BodyOutline body_;
  NoiseGenerator noise_;
  std::vector<std::unique_ptr<Critic>> critics_;
  ObstacleCritic* obstacle_ = nullptr;   // owned by critics_; asked which rollouts collided
  std::optional<control::DistanceField> field_;
  ClearMask clear_;
  PathField path_;
  Eigen::ArrayXf u_v_, u_w_;             // the control sequence U [T]
  std::array<float, 4> history_v_{}, history_w_{};  // the last commands sent, oldest first
  Array eps_v_, eps_w_, v_req_, w_req_, v_, w_, x_, y_, yaw_, cos_, sin_;  // [K x T]
  Eigen::ArrayXf costs_, weights_;       // [K]
};

}  // namespace turtlebot_recon::mppi
