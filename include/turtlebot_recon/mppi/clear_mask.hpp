// Where the body is clear for sure: one byte per map cell, so that the obstacle critic answers
// most rollout poses (those far from every obstacle) with one lookup instead of the distance
// field's bilinear one (body_field.hpp).
//
// Cell (r, c) is clear when its field value d satisfies d - R >= band + 1.5 res (R: the body's
// circumscribed radius about base_footprint). Any (x, y) in that cell lies within res / sqrt(2)
// of its centre, and the four centres the field interpolates between lie within res sqrt(2) of
// it; the field is 1-Lipschitz, so there field.at(x, y) >= d - 1.5 res and body_clearance
// returns its cap `band` (no cost). Off the grid nothing is clear (off the grid collides).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "turtlebot_recon/body_field.hpp"

namespace turtlebot_recon::mppi {

class ClearMask {
 public:
  ClearMask() = default;
  ClearMask(const control::DistanceField& field, double origin_x_m, double origin_y_m,
            double radius_m, double band_m)
      : rows_(field.rows()), cols_(field.cols()),
        inv_res_(static_cast<float>(1.0 / field.resolution())),
        ox_(static_cast<float>(origin_x_m)), oy_(static_cast<float>(origin_y_m)) {
    const double need = radius_m + band_m + 1.5 * field.resolution();
    clear_.resize(static_cast<size_t>(rows_) * cols_);
    for (int r = 0; r < rows_; ++r)
      for (int c = 0; c < cols_; ++c)
        clear_[static_cast<size_t>(r) * cols_ + c] = field.cell(r, c) >= need ? 1 : 0;
  }

  bool clear(float x, float y) const {
    const float fc = (x - ox_) * inv_res_, fr = (y - oy_) * inv_res_;
    if (!(fc >= 0.0f && fr >= 0.0f && fc < cols_ && fr < rows_)) return false;  // NaN: false
    return clear_[static_cast<size_t>(fr) * cols_ + static_cast<size_t>(fc)] != 0;
  }

 private:
  int rows_ = 0, cols_ = 0;
  float inv_res_ = 1.0f, ox_ = 0.0f, oy_ = 0.0f;   // float: the rollouts' poses are
  std::vector<std::uint8_t> clear_;
};

}  // namespace turtlebot_recon::mppi
