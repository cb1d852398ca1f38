// Obstacle critic: the robot's body (the oriented box of the waffle_pi, the disc of a round
// robot) against the distance field of the occupancy grid, at every pose of every rollout.
//
//   collision   clearance < margin_m, or the pose off the grid: cost += collision_cost once,
//               and the rest of that rollout is not looked at (it is out of the running);
//   repulsion   clearance c < band_m: cost += weight x mean_t (band_m - c) / band_m.
//
// A robot that already stands nearer than margin_m (brushing a wall after a tracking error)
// collides only where a pose comes nearer still: it may drive away.
//
// The clearance, cheapest first: ClearMask's one byte (far from everything: no cost); for a
// box, a lower bound from a cover of discs along its length (each disc's centre lookup less
// its radius; the discs bulge past the box's sides by at most kBulge_m), which answers every
// pose it puts at or beyond margin_m (repulsion from the bound: at most kBulge_m more than
// the box's); below that, body_field.hpp's body_clearance, the box's outline, decides.
// Down a corridor that leaves the box a few cm a side, 3 lookups a pose instead of ~27.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "turtlebot_recon/mppi/critic.hpp"

namespace turtlebot_recon::mppi {

struct ObstacleParams {
  double weight = 2.0;             // repulsion, per unit of mean band intrusion (0..1); 0: none
  double band_m = 0.15;            // repulsion within this clearance of the body (m); the
                                   // optimizer's ClearMask is built with it
  double margin_m = 0.005;         // the body nearer an obstacle's edge than this collides (m)
  double collision_cost = 1000.0;  // added once to a colliding rollout: out of the running
};

class ObstacleCritic : public Critic {
 public:
  static constexpr double kBulge_m = 0.01;  // the disc cover past the box's sides, at most

  explicit ObstacleCritic(const ObstacleParams& p) : p_(p) {}
  const char* name() const override { return "obstacle"; }

  void score(const CriticData& d, Eigen::ArrayXf& costs) override {
    const Eigen::Index n = d.x.rows(), T = d.x.cols();
    collided_.assign(static_cast<size_t>(n), 0);
    cover(d.body);
    const double band = std::max(p_.band_m, p_.margin_m);
    const double start = control::body_clearance(d.field, d.body, d.start.x, d.start.y,
                                                 d.start.yaw, band);
    const double collide_below = std::min(p_.margin_m, start - 1e-3);
    const float repulse = static_cast<float>(p_.weight / (band * T));
    parallel_for(n, d.threads, [&](Eigen::Index k0, Eigen::Index k1) {
      for (Eigen::Index t = 0; t < T; ++t) {
        const float* xs = d.x.col(t).data();
        const float* ys = d.y.col(t).data();
        const float* yaws = d.yaw.col(t).data();
        const float* cs = d.cos_yaw.col(t).data();
        const float* ss = d.sin_yaw.col(t).data();
        for (Eigen::Index k = k0; k < k1; ++k) {
          if (collided_[k] || d.clear.clear(xs[k], ys[k])) continue;
          double c = -1.0;                                  // off the grid: collides
          if (d.field.contains(xs[k], ys[k])) {
            c = lower_bound(d.field, xs[k], ys[k], cs[k], ss[k], band);
            if (c < p_.margin_m)
              c = control::body_clearance(d.field, d.body, xs[k], ys[k], yaws[k], band);
          }
          if (c < collide_below) {
            collided_[k] = 1;
            costs[k] += static_cast<float>(p_.collision_cost);
          } else if (c < band) {
            costs[k] += repulse * static_cast<float>(band - c);
          }
        }
      }
    });
  }

  // Whether rollout k collided in the last score().
  bool collided(Eigen::Index k) const { return collided_[static_cast<size_t>(k)] != 0; }

 private:
  // The disc cover of the body (robot frame): a round robot's own disc; a box's discs along
  // its length, as few as keep their bulge past its sides within kBulge_m.
  void cover(const control::BodyOutline& body) {
    centres_.clear();
    if (body.round) {
      centres_.push_back({0.0, 0.0});
      radius_ = body.radius_m;
      return;
    }
    double x0 = body.outline[0].x, x1 = x0, y0 = body.outline[0].y, y1 = y0;
    for (const auto& p : body.outline) {
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
    // a disc of radius hypot(h, hw) over 2 h of the box's length bulges kBulge_m past its sides
    const double hw = 0.5 * (y1 - y0);
    const double half_step = std::sqrt((hw + kBulge_m) * (hw + kBulge_m) - hw * hw);
    const int discs = std::max(1, static_cast<int>(std::ceil((x1 - x0) / (2.0 * half_step))));
    const double step = (x1 - x0) / discs;
    for (int i = 0; i < discs; ++i) centres_.push_back({x0 + (i + 0.5) * step, 0.5 * (y0 + y1)});
    radius_ = std::hypot(0.5 * step, hw);
  }

  // min over the cover's discs of (field at its centre - its radius), capped at max_m: a lower
  // bound of the body's clearance (the body lies within the discs).
  double lower_bound(const control::DistanceField& field, float x, float y, float c, float s,
                     double max_m) const {
    double least = max_m + radius_;
    for (const auto& p : centres_)
      least = std::min(least, field.at(x + c * p.x - s * p.y, y + s * p.x + c * p.y));
    return std::min(least - radius_, max_m);
  }

  ObstacleParams p_;
  std::vector<std::uint8_t> collided_;
  std::vector<planning::Vec2> centres_;
  double radius_ = 0.0;
};

}  // namespace turtlebot_recon::mppi
