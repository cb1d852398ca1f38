// The dynamic window approach (Fox, Burgard & Thrun 1997), as seed 001 drives with it: sample
// (v, w) evenly in the dynamic window, roll each out as an arc over the horizon, reject the arcs
// whose body meets an obstacle or that could not stop within their clearance, and take the best
// of  alpha heading + beta clearance + gamma velocity,  each term normalised over the window.
//
//   1. window     Vd = [v - a_v T, v + a_v T] x [w - a_w T, w + a_w T] around the measured
//                 (v, w), T the control period, intersected with the robot's limits Vs
//                 (and v <= the speed from which it still stops at the goal, sqrt(2 a_v d)).
//   2. sample     n_v x n_w pairs evenly spaced over Vd (its edges included).
//   3. roll out   each pair held for the horizon, poses every dt on the exact arc; the arc
//                 ends early at the goal (the robot stops there; beyond it nothing is checked).
//   4. admissible the body (body_field.hpp: the oriented box by its outline, a round robot by
//                 its disc) keeps margin_m off every obstacle at every pose, no pose's centre is
//                 on unknown space (optional), and the braking distance v^2 / (2 a_v) fits in
//                 the least clearance along the arc (Fox's admissible velocities, in seed 001's
//                 form). A robot already nearer than the margin may drive through poses no
//                 nearer than it stands (escaping), as the follower does.
//   5. score      heading   = pi - |bearing of the target from the arc's end pose|  (Fox's
//                             180 - theta, at the end of the horizon; 1 when it ends on it)
//                 clearance = the least body clearance along the arc, capped at clearance_max_m
//                             (or less: the query's cap, the plan's own clearance ahead)
//                 velocity  = v
//                 each divided by its sum over the admissible arcs (Fox's normalisation), then
//                 weighted and summed; the best admissible arc wins (ties: the first sampled).
//
// Grids as everywhere: int8 occupancy (-1 unknown, 0..100), row-major, row 0 at the smallest y,
// origin the corner of cell (0, 0). The distance field is built on a window of the grid around
// the robot, just large enough for the arcs' bodies and the clearance cap.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/body_field.hpp"

namespace turtlebot_recon::control {

struct Pose2 {
  double x, y, yaw;
};

struct DwaConfig {
  // the robot (RobotSpec): limits and body
  double max_linear_mps = 0.26;
  double min_linear_mps = 0.0;         // < 0 allows reversing; DWA here drives forward only
  double max_angular_radps = 1.82;
  double linear_accel_mps2 = 2.5;
  double angular_accel_radps2 = 3.2;
  Footprint footprint{};               // the box (length/width/offset) or a disc (radius)
  double outline_spacing_m = 0.05;     // the box's outline points this far apart at most
  // the window and the rollouts
  int linear_samples = 20;             // n_v
  int angular_samples = 20;            // n_w
  double horizon_s = 2.0;
  double dt_s = 0.1;                   // rollout step
  // admissibility and scoring
  double margin_m = 0.005;             // body nearer an obstacle's edge than this: collision
  double clearance_max_m = 0.3;        // clearance scored up to this (farther is as good)
  bool unknown_is_obstacle = true;     // a pose's centre on unknown space (or off the grid)
  int occupied_threshold = 65;
  double heading_weight = 0.75;        // alpha
  double clearance_weight = 0.18;      // beta
  double velocity_weight = 0.08;       // gamma
};

// Throws std::invalid_argument ("dwa: ...") naming the first bad field.
inline void validate(const DwaConfig& c) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("dwa: " + what); };
  auto pos = [&](double v, const char* name) {
    if (!(std::isfinite(v) && v > 0)) fail(std::string(name) + " must be > 0, got " + std::to_string(v));
  };
  pos(c.max_linear_mps, "max_linear_mps");
  pos(c.max_angular_radps, "max_angular_radps");
  pos(c.linear_accel_mps2, "linear_accel_mps2");
  pos(c.angular_accel_radps2, "angular_accel_radps2");
  pos(c.outline_spacing_m, "outline_spacing_m");
  pos(c.horizon_s, "horizon_s");
  pos(c.dt_s, "dt_s");
  pos(c.clearance_max_m, "clearance_max_m");
  if (!(std::isfinite(c.min_linear_mps) && c.min_linear_mps <= c.max_linear_mps))
    fail("min_linear_mps must be <= max_linear_mps");
  if (c.linear_samples < 1 || c.angular_samples < 1) fail("linear_samples and angular_samples must be >= 1");
  if (c.horizon_s / c.dt_s > 10000) fail("horizon_s / dt_s must be <= 10000 steps");
  if (!(std::isfinite(c.margin_m) && c.margin_m >= 0)) fail("margin_m must be >= 0");
  for (double w : {c.heading_weight, c.clearance_weight, c.velocity_weight})
    if (!(std::isfinite(w) && w >= 0)) fail("the weights must be >= 0");
  planning::validate(c.footprint, "dwa");
}


// What the robot does now and where it heads: the measured state, the look-ahead point on the
// global path (the heading term aims at it) and the goal (the arcs end there).
struct DwaQuery {
  Pose2 pose{0, 0, 0};
  double v = 0.0, w = 0.0;              // measured (m/s, rad/s)
  double period_s = 0.1;                // control period: how far the window reaches (s)
  double target_x = 0.0, target_y = 0.0;
  double goal_x = 0.0, goal_y = 0.0;
  double goal_radius_m = 0.0;           // an arc ends at its first pose this near the goal
  double goal_distance_m = INFINITY;    // along the path: v <= sqrt(2 a_v d)
  // Clearance is scored up to min(clearance_max_m, the body's least clearance at these poses):
  // the plan's own poses ahead, so that standing in the open never outscores entering the
  // corridor the plan goes through. None: clearance_max_m.
  std::vector<Pose2> path_ahead;
};

struct DynamicWindow {
  double v_lo, v_hi, w_lo, w_hi;
};

struct DwaArc {
  double v, w;
  bool admissible = false;
  int poses = 0;                        // rolled-out poses (the start included) until the end,
                                        // the goal or the first collision
  double clearance_m = 0.0;             // least body clearance along it (capped)
  double heading = 0.0, clearance = 0.0, velocity = 0.0;   // the raw terms
  double score = -INFINITY;             // the weighted normalised sum; -inf when inadmissible
};

struct DwaResult {
  DynamicWindow window{};
  std::vector<DwaArc> arcs;             // n_v x n_w, v-major
  double clearance_cap_m = 0.0;         // clearance scored up to this
  int best = -1;                        // index into arcs; -1: no admissible arc
};

// 1. The dynamic window: velocities reachable within one control period, within the limits.
inline DynamicWindow dynamic_window(const DwaConfig& c, const DwaQuery& q) {
  const double v = std::isfinite(q.v) ? q.v : 0.0, w = std::isfinite(q.w) ? q.w : 0.0;
  DynamicWindow d;
  double v_top = c.max_linear_mps;
  if (std::isfinite(q.goal_distance_m))
    v_top = std::min(v_top, std::sqrt(2.0 * c.linear_accel_mps2 * std::max(q.goal_distance_m, 0.0)));
  d.v_lo = std::max(v - c.linear_accel_mps2 * q.period_s, c.min_linear_mps);
  d.v_hi = std::min(v + c.linear_accel_mps2 * q.period_s, v_top);
  if (d.v_hi < d.v_lo) {   // faster than the limits (or the goal) allow: the slowest reachable
    d.v_lo = std::clamp(d.v_lo, c.min_linear_mps, c.max_linear_mps);
    d.v_hi = d.v_lo;
  }
  d.w_lo = std::max(w - c.angular_accel_radps2 * q.period_s, -c.max_angular_radps);
  d.w_hi = std::min(w + c.angular_accel_radps2 * q.period_s, c.max_angular_radps);
  if (d.w_hi < d.w_lo) {
    d.w_lo = std::clamp(d.w_lo, -c.max_angular_radps, c.max_angular_radps);
    d.w_hi = d.w_lo;
  }
  return d;
}

// k-th of n evenly spaced values over [lo, hi] (the middle one when n = 1).
inline double spaced(double lo, double hi, int k, int n) {
  return n == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * k / (n - 1);
}

// 3. The pose after t seconds on the arc (v, w) from p (exact; straight when w ~ 0).
inline Pose2 arc_pose(const Pose2& p, double v, double w, double t) {
  const double th = w * t;
  const double chord = std::fabs(th) < 1e-9 ? v * t : 2.0 * v / w * std::sin(0.5 * th);
  const double mid = p.yaw + 0.5 * th;
  return {p.x + chord * std::cos(mid), p.y + chord * std::sin(mid), p.yaw + th};
}

inline double wrap(double a) { return std::remainder(a, 2.0 * planning::kPi); }

// The whole DWA step. The grid window is cut around the robot here; everything it needs lives
// in `field_buf` between calls of one controller (no allocation once it has grown).
class Dwa {
 public:
  explicit Dwa(const DwaConfig& config) : c_(config) {
    validate(c_);
    body_ = outline_body(c_.footprint, c_.outline_spacing_m);
    steps_ = std::max(1, static_cast<int>(std::ceil(c_.horizon_s / c_.dt_s - 1e-9)));
  }

  const DwaConfig& config() const { return c_; }
  int steps() const { return steps_; }

  DwaResult plan(const std::int8_t* occupancy, int rows, int cols, double resolution_m,
                 double origin_x_m, double origin_y_m, const DwaQuery& q) {
    DwaResult out;
    out.window = dynamic_window(c_, q);
    build_field(occupancy, rows, cols, resolution_m, origin_x_m, origin_y_m, q, out.window);
    cap_ = c_.clearance_max_m;
    for (const Pose2& p : q.path_ahead)
      cap_ = std::min(cap_, body_clearance(field_, body_, p.x, p.y, p.yaw, c_.clearance_max_m));
    cap_ = std::max(cap_, c_.margin_m);
    out.clearance_cap_m = cap_;
    const int nv = c_.linear_samples, nw = c_.angular_samples;
    out.arcs.resize(static_cast<size_t>(nv) * nw);
    for (int i = 0; i < nv; ++i)
      for (int j = 0; j < nw; ++j) {
        DwaArc& a = out.arcs[static_cast<size_t>(i) * nw + j];
        a.v = spaced(out.window.v_lo, out.window.v_hi, i, nv);
        a.w = spaced(out.window.w_lo, out.window.w_hi, j, nw);
        evaluate(a, q);
      }
    out.best = select(out.arcs);
    return out;
  }

  // The poses (the start included) of arc (v, w) from `pose` up to `n` poses (<= steps + 1).
  std::vector<Pose2> rollout(const Pose2& pose, double v, double w, int n) const {
    std::vector<Pose2> poses;
    for (int k = 0; k < std::min(n, steps_ + 1); ++k) poses.push_back(arc_pose(pose, v, w, time_at(k)));
    return poses;
  }

 private:
  double time_at(int k) const { return std::min(k * c_.dt_s, c_.horizon_s); }

  // The distance field on the window of the grid the arcs' bodies can reach, plus the
  // clearance cap (obstacles farther than that from every arc do not change any score).
  void build_field(const std::int8_t* occ, int rows, int cols, double res, double ox, double oy,
                   const DwaQuery& q, const DynamicWindow& d) {
    occ_ = occ, rows_ = rows, cols_ = cols, res_ = res, ox_ = ox, oy_ = oy;
    const double reach = std::max(std::fabs(d.v_lo), std::fabs(d.v_hi)) * c_.horizon_s +
                         body_.radius_m + c_.clearance_max_m + 2.0 * res;
    const int c0 = std::clamp(static_cast<int>(std::floor((q.pose.x - reach - ox) / res)), 0, cols - 1);
    const int c1 = std::clamp(static_cast<int>(std::ceil((q.pose.x + reach - ox) / res)), c0 + 1, cols);
    const int r0 = std::clamp(static_cast<int>(std::floor((q.pose.y - reach - oy) / res)), 0, rows - 1);
    const int r1 = std::clamp(static_cast<int>(std::ceil((q.pose.y + reach - oy) / res)), r0 + 1, rows);
    crop_.resize(static_cast<size_t>(r1 - r0) * (c1 - c0));
    for (int r = r0; r < r1; ++r)
      std::copy(occ + static_cast<size_t>(r) * cols + c0, occ + static_cast<size_t>(r) * cols + c1,
                crop_.begin() + static_cast<size_t>(r - r0) * (c1 - c0));
    field_ = DistanceField(crop_.data(), r1 - r0, c1 - c0, res, ox + c0 * res, oy + r0 * res,
                           c_.occupied_threshold);
  }

  bool unknown_at(double x, double y) const {
    const double fc = std::floor((x - ox_) / res_), fr = std::floor((y - oy_) / res_);
    if (!(fc >= 0 && fr >= 0 && fc < cols_ && fr < rows_)) return true;
    return occ_[static_cast<size_t>(fr) * cols_ + static_cast<size_t>(fc)] < 0;
  }

  // 3-5 for one arc: roll out, check every pose, the raw terms.
  void evaluate(DwaArc& a, const DwaQuery& q) const {
    const double cap = cap_;
    const double margin = c_.margin_m;
    const double goal_r2 = q.goal_radius_m * q.goal_radius_m;
    const double c_start = body_clearance(field_, body_, q.pose.x, q.pose.y, q.pose.yaw, cap);
    bool escaping = c_start < margin;                 // may move through no-nearer poses
    bool on_unknown = c_.unknown_is_obstacle && unknown_at(q.pose.x, q.pose.y);
    double least = escaping ? cap : c_start;          // over the poses past the escape
    Pose2 end = q.pose;
    a.poses = 1;
    // the arc by constant steps: each turns by w dt and moves by the chord of that turn
    const double turn = a.w * c_.dt_s;
    const double chord = std::fabs(turn) < 1e-9 ? a.v * c_.dt_s : 2.0 * a.v / a.w * std::sin(0.5 * turn);
    const double step_c = std::cos(turn), step_s = std::sin(turn);
    double hc = std::cos(q.pose.yaw + 0.5 * turn), hs = std::sin(q.pose.yaw + 0.5 * turn);
    // The body is checked at the poses where it has moved a grid cell since the last one
    // checked (the field resolves no finer; at most every dt), and at the arc's end:
    // no point of it moves more than |v| + |w| r per second (r: the circumscribed radius).
    const double motion = (std::fabs(a.v) + std::fabs(a.w) * body_.radius_m) * c_.dt_s;
    double moved = 0.0;
    Pose2 p = q.pose;
    for (int k = 1; k <= steps_; ++k) {
      if (k * c_.dt_s > c_.horizon_s + 1e-9) {         // a last, shorter step to the horizon
        p = arc_pose(q.pose, a.v, a.w, c_.horizon_s);
      } else {
        p = {p.x + chord * hc, p.y + chord * hs, p.yaw + turn};
        const double c2 = hc * step_c - hs * step_s;
        hs = hs * step_c + hc * step_s, hc = c2;
      }
      const double gx = p.x - q.goal_x, gy = p.y - q.goal_y;
      const bool at_goal = gx * gx + gy * gy <= goal_r2;
      moved += motion;
      if (moved >= res_ - 1e-12 || at_goal || k == steps_) {   // the body moved a cell
        moved = 0.0;
        const double clr = body_clearance(field_, body_, p.x, p.y, p.yaw, cap);
        if (escaping && clr >= c_start - 1e-9) {
          if (clr >= margin) escaping = false;
        } else {
          escaping = false;
          if (clr < margin) return;                    // collision: inadmissible
          least = std::min(least, clr);
        }
      }
      if (c_.unknown_is_obstacle) {
        const bool unk = unknown_at(p.x, p.y);
        if (unk && !on_unknown) return;                // into unknown space: inadmissible
        on_unknown = on_unknown && unk;                // leaving the unknown it started on
      }
      end = p;
      a.poses = k + 1;
      if (at_goal) break;                              // it stops there
    }
    least = std::max(least, 0.0);
    // Fox's admissibility: it can brake to a stop within its clearance
    if (a.v * a.v / (2.0 * c_.linear_accel_mps2) > least + 1e-12) return;
    a.admissible = true;
    a.clearance_m = least;
    const double tx = q.target_x - end.x, ty = q.target_y - end.y;
    const bool on_target = tx * tx + ty * ty <= 1e-6;
    a.heading = on_target ? planning::kPi : planning::kPi - std::fabs(wrap(std::atan2(ty, tx) - end.yaw));
    a.clearance = std::min(least, cap);
    a.velocity = a.v;
  }

  // 5. Normalise each term by its sum over the admissible arcs; the best weighted sum.
  int select(std::vector<DwaArc>& arcs) const {
    double sh = 0, sc = 0, sv = 0;
    for (const DwaArc& a : arcs)
      if (a.admissible) sh += a.heading, sc += a.clearance, sv += std::fabs(a.velocity);
    auto norm = [](double x, double sum) { return sum > 1e-12 ? x / sum : 0.0; };
    int best = -1;
    for (size_t i = 0; i < arcs.size(); ++i) {
      DwaArc& a = arcs[i];
      if (!a.admissible) continue;
      a.score = c_.heading_weight * norm(a.heading, sh) + c_.clearance_weight * norm(a.clearance, sc) +
                c_.velocity_weight * norm(std::fabs(a.velocity), sv);
      if (best < 0 || a.score > arcs[best].score) best = static_cast<int>(i);
    }
    return best;
  }

  DwaConfig c_;
  BodyOutline body_;
  int steps_ = 1;
  double cap_ = 0.0;                    // this plan's clearance cap
  std::vector<std::int8_t> crop_;
  DistanceField field_;
  const std::int8_t* occ_ = nullptr;
  int rows_ = 0, cols_ = 0;
  double res_ = 1.0, ox_ = 0.0, oy_ = 0.0;
};

}  // namespace turtlebot_recon::control
