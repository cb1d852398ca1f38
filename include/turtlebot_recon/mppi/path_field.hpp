// The local path for MPPI's path critics: its points with their arc lengths, and the distance
// to it on a small grid around it, so that "how far is this rollout pose from the path" is
// one bilinear lookup instead of a search over segments (2000 x 56 poses a cycle).
//
// The grid covers the path's bounding box padded by `pad_m` (the rollouts' reach); the path's
// points, taken every half cell along its segments, are the features of an exact Euclidean
// distance transform (distance_field.hpp). Off the grid the nearest edge value plus the
// distance past the edge is returned (a lower bound, large enough to push rollouts back).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "turtlebot_recon/distance_field.hpp"

namespace turtlebot_recon::mppi {

class PathField {
 public:
  // path: n >= 1 (x, y) points, row-major; resolution of the distance grid (m).
  void build(const double* path, int n, double resolution_m, double pad_m) {
    if (n < 1) throw std::invalid_argument("PathField: the path needs at least one point");
    res_ = resolution_m;
    px_.assign(path, path + 2 * n);
    s_.assign(n, 0.0);
    for (int i = 1; i < n; ++i)
      s_[i] = s_[i - 1] + std::hypot(px_[2 * i] - px_[2 * i - 2], px_[2 * i + 1] - px_[2 * i - 1]);
    double x0 = px_[0], x1 = px_[0], y0 = px_[1], y1 = px_[1];
    for (int i = 1; i < n; ++i) {
      x0 = std::min(x0, px_[2 * i]);
      x1 = std::max(x1, px_[2 * i]);
      y0 = std::min(y0, px_[2 * i + 1]);
      y1 = std::max(y1, px_[2 * i + 1]);
    }
    ox_ = x0 - pad_m;
    oy_ = y0 - pad_m;
    cols_ = static_cast<int>(std::ceil((x1 - x0 + 2 * pad_m) / res_)) + 1;
    rows_ = static_cast<int>(std::ceil((y1 - y0 + 2 * pad_m) / res_)) + 1;
    mask_.assign(static_cast<size_t>(rows_) * cols_, 0);
    auto mark = [this](double x, double y) {
      const int c = static_cast<int>((x - ox_) / res_), r = static_cast<int>((y - oy_) / res_);
      if (r >= 0 && c >= 0 && r < rows_ && c < cols_) mask_[static_cast<size_t>(r) * cols_ + c] = 1;
    };
    mark(px_[0], px_[1]);
    for (int i = 1; i < n; ++i) {
      const double ax = px_[2 * i - 2], ay = px_[2 * i - 1], bx = px_[2 * i], by = px_[2 * i + 1];
      const double len = std::hypot(bx - ax, by - ay);
      const int k = std::max(1, static_cast<int>(std::ceil(len / (0.5 * res_))));
      for (int j = 1; j <= k; ++j) mark(ax + (bx - ax) * j / k, ay + (by - ay) * j / k);
    }
    dist_.resize(mask_.size());
    planning::distance_transform(mask_.data(), rows_, cols_, res_, dist_.data());
  }

  int size() const { return static_cast<int>(s_.size()); }
  double length() const { return s_.back(); }
  double x(int i) const { return px_[2 * i]; }
  double y(int i) const { return px_[2 * i + 1]; }

  // The point at arc length s (clamped to the path's ends).
  void point_at(double s, double& x, double& y) const {
    const int n = size();
    if (n == 1 || s <= 0) { x = px_[0]; y = px_[1]; return; }
    if (s >= s_.back()) { x = px_[2 * n - 2]; y = px_[2 * n - 1]; return; }
    const int i = static_cast<int>(std::upper_bound(s_.begin(), s_.end(), s) - s_.begin());
    const double f = (s - s_[i - 1]) / std::max(s_[i] - s_[i - 1], 1e-12);
    x = px_[2 * i - 2] + f * (px_[2 * i] - px_[2 * i - 2]);
    y = px_[2 * i - 1] + f * (px_[2 * i + 1] - px_[2 * i - 1]);
  }

  // Metres from (x, y) to the path (to its cells' centres), bilinear between cell centres.
  float distance(float x, float y) const {
    const float fc = (x - static_cast<float>(ox_)) / static_cast<float>(res_) - 0.5f;
    const float fr = (y - static_cast<float>(oy_)) / static_cast<float>(res_) - 0.5f;
    const float cc = std::clamp(fc, 0.0f, cols_ - 1.0f), rc = std::clamp(fr, 0.0f, rows_ - 1.0f);
    const int c0 = std::min(static_cast<int>(cc), cols_ - 2 < 0 ? 0 : cols_ - 2);
    const int r0 = std::min(static_cast<int>(rc), rows_ - 2 < 0 ? 0 : rows_ - 2);
    const int c1 = std::min(c0 + 1, cols_ - 1), r1 = std::min(r0 + 1, rows_ - 1);
    const float tc = cc - c0, tr = rc - r0;
    const float* d = dist_.data();
    const float top = (1 - tc) * d[r0 * cols_ + c0] + tc * d[r0 * cols_ + c1];
    const float bottom = (1 - tc) * d[r1 * cols_ + c0] + tc * d[r1 * cols_ + c1];
    const float outside = static_cast<float>(res_) * (std::fabs(fc - cc) + std::fabs(fr - rc));
    return (1 - tr) * top + tr * bottom + outside;
  }

 private:
  double res_ = 0.05, ox_ = 0.0, oy_ = 0.0;
  int rows_ = 0, cols_ = 0;
  std::vector<double> px_, s_;
  std::vector<std::uint8_t> mask_;
  std::vector<float> dist_;
};

}  // namespace turtlebot_recon::mppi
