// The robot's body against a distance field: the obstacle test of the sampling controllers.
//
// MPPI scores thousands of rollout poses per cycle and DWA hundreds of arcs, too many for the
// exact polygon test of footprint.hpp. Here the body is looked up in a Euclidean distance field
// of the obstacle cells: a round robot by its centre (field - radius), a box by points along
// its outline (the least field value; a disc cover of a box would bulge several centimetres
// past its sides and close a corridor the box fits). Away from obstacles one lookup at
// base_footprint answers (beyond the circumscribed radius + the distance of interest).
//
// The field holds, at each cell centre, the distance to the nearest obstacle cell's centre
// less half a cell: the distance to the obstacle square's near edge along the grid axes, the
// convention of footprint.hpp's margins. Between centres it is interpolated bilinearly;
// outside the grid it takes the value of the nearest edge cell (the grid's own unknowns are
// no obstacles either: the planner's convention). Grids as everywhere: row-major, row 0 at
// the smallest y, cell (r, c) centred at origin + ((c + 0.5) res, (r + 0.5) res).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/distance_field.hpp"
#include "turtlebot_recon/footprint.hpp"

namespace turtlebot_recon::control {

using planning::Footprint;
using planning::Vec2;

class DistanceField {
 public:
  DistanceField() = default;

  // occupancy int8 (-1 unknown, 0..100): cells >= occupied_threshold are obstacles; with none
  // at all, every value is `empty_m` (a large finite distance, so costs stay finite).
  DistanceField(const std::int8_t* occupancy, int rows, int cols, double resolution_m,
                double origin_x_m, double origin_y_m, int occupied_threshold,
                double empty_m = 1e3)
      : rows_(rows), cols_(cols), res_(resolution_m), ox_(origin_x_m), oy_(origin_y_m) {
    if (rows <= 0 || cols <= 0) throw std::invalid_argument("DistanceField: empty grid");
    if (!(std::isfinite(resolution_m) && resolution_m > 0))
      throw std::invalid_argument("DistanceField: resolution must be > 0 m");
    const size_t n = static_cast<size_t>(rows) * static_cast<size_t>(cols);
    std::vector<std::uint8_t> mask(n);
    for (size_t i = 0; i < n; ++i) mask[i] = occupancy[i] >= occupied_threshold ? 1 : 0;
    dist_.resize(n);
    planning::distance_transform(mask.data(), rows, cols, resolution_m, dist_.data());
    const float half = static_cast<float>(0.5 * resolution_m);
    for (float& d : dist_) d = std::isfinite(d) ? d - half : static_cast<float>(empty_m);
  }

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  double resolution() const { return res_; }
  // Whether (x, y) lies on the grid (the field is extrapolated beyond it).
  bool contains(double x, double y) const {
    const double c = (x - ox_) / res_, r = (y - oy_) / res_;
    return c >= 0 && r >= 0 && c < cols_ && r < rows_;
  }
  double cell(int r, int c) const { return dist_[static_cast<size_t>(r) * cols_ + c]; }

  // Metres from (x, y) to the nearest obstacle's edge, bilinear between cell centres.
  double at(double x, double y) const {
    const double fc = std::clamp((x - ox_) / res_ - 0.5, 0.0, cols_ - 1.0);
    const double fr = std::clamp((y - oy_) / res_ - 0.5, 0.0, rows_ - 1.0);
    const int c0 = std::min(static_cast<int>(fc), cols_ - 1), r0 = std::min(static_cast<int>(fr), rows_ - 1);
    const int c1 = std::min(c0 + 1, cols_ - 1), r1 = std::min(r0 + 1, rows_ - 1);
    const double tc = fc - c0, tr = fr - r0;
    const double top = (1 - tc) * cell(r0, c0) + tc * cell(r0, c1);
    const double bottom = (1 - tc) * cell(r1, c0) + tc * cell(r1, c1);
    return (1 - tr) * top + tr * bottom;
  }

 private:
  int rows_ = 0, cols_ = 0;
  double res_ = 1.0, ox_ = 0.0, oy_ = 0.0;
  std::vector<float> dist_;
};

// The body for the field lookups (robot frame): a round robot is its disc; a box is the
// points of its outline, spaced at most `spacing_m` apart (corners included), plus its
// inscribed disc at the box's centre (an obstacle wholly inside the outline).
struct BodyOutline {
  bool round = true;
  double radius_m = 0.0;       // a round robot's radius; a box's circumscribed radius about
                               // base_footprint (beyond it from the origin: clear for sure)
  double inscribed_m = 0.0;    // half the box's shorter side
  Vec2 centre{0.0, 0.0};       // the box's centre
  std::vector<Vec2> outline;   // points along the box's edges
};

inline BodyOutline outline_body(const Footprint& fp, double spacing_m) {
  planning::validate(fp, "outline_body");
  if (!(std::isfinite(spacing_m) && spacing_m > 0))
    throw std::invalid_argument("outline_body: spacing_m must be > 0");
  BodyOutline out;
  out.radius_m = fp.radius_m;
  if (fp.round()) return out;
  out.round = false;
  const double hl = 0.5 * fp.length_m, hw = 0.5 * fp.width_m;
  out.radius_m = std::max(fp.radius_m, std::hypot(std::fabs(fp.offset_x_m) + hl, hw));
  out.inscribed_m = std::min(hl, hw);
  out.centre = {fp.offset_x_m, 0.0};
  const Vec2 corners[4] = {{fp.offset_x_m - hl, -hw}, {fp.offset_x_m + hl, -hw},
                           {fp.offset_x_m + hl, hw}, {fp.offset_x_m - hl, hw}};
  for (int k = 0; k < 4; ++k) {  // each edge from its corner, the next corner starting the next
    const Vec2 a = corners[k], b = corners[(k + 1) % 4];
    const int n = std::max(1, static_cast<int>(std::ceil(std::hypot(b.x - a.x, b.y - a.y) / spacing_m)));
    for (int i = 0; i < n; ++i)
      out.outline.push_back({a.x + (b.x - a.x) * i / n, a.y + (b.y - a.y) * i / n});
  }
  return out;
}

// Clearance (m) of the body at pose (x, y, yaw), capped at max_m: for a box, the least field
// value along its outline (and its inscribed disc); negative where it overlaps an obstacle.
// The outline's spacing s costs at most s / 2 where an obstacle corner pokes between two points.
// Far from obstacles one lookup answers: the field at base_footprint beyond the circumscribed
// radius + max_m.
inline double body_clearance(const DistanceField& field, const BodyOutline& body, double x,
                             double y, double yaw, double max_m) {
  const double d0 = field.at(x, y);
  if (body.round) return std::min(d0 - body.radius_m, max_m);
  if (d0 - body.radius_m >= max_m) return max_m;
  const double c = std::cos(yaw), s = std::sin(yaw);
  auto at = [&](const Vec2& p) { return field.at(x + c * p.x - s * p.y, y + s * p.x + c * p.y); };
  double least = max_m;
  for (const Vec2& p : body.outline) least = std::min(least, at(p));
  // The inscribed disc only says "overlap": on a corridor's centre line the interpolated field
  // runs up to half a cell low, where the outline's own points are exact.
  const double inner = at(body.centre) - body.inscribed_m;
  return inner < 0.0 ? std::min(least, inner) : least;
}

}  // namespace turtlebot_recon::control
