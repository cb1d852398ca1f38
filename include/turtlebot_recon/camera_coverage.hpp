// Camera coverage: the wall cells a forward camera has seen well enough to read a tag on them
// (seed 000's "second map of what the camera has seen", here with the range and viewing angle
// a tag detector needs).
//
// The camera sits at (x, y) m with heading yaw rad in the grid's frame. `rays` rays fan out
// evenly over its horizontal field of view, at yaw - hfov/2 + hfov k / (rays - 1), k = 0 ..
// rays - 1 (both edges included; one ray: along yaw). rays = 0 picks enough rays to leave no
// cell of a straight wall face unhit within max_range and max_incidence (auto_ray_count).
// Each ray is the segment from the camera to max_range_m away, walked cell by cell with the exact
// traversal of grid_traversal.hpp (Amanatides & Woo), so a cell counts as within range when
// the ray enters it within max_range_m. That walk is 4-connected: a ray cannot slip between
// two diagonal neighbours, so a one-cell-thick diagonal wall stops it as a straight one does
// (a Bresenham line, 8-connected, would leak through). A ray stops
//   - at the grid's edge: nothing is known beyond it (a camera off the grid sees nothing);
//   - on an unknown cell (value < 0): the lidar has not seen what lies there, so the camera
//     cannot be certified to have seen the wall behind it;
//   - on the first occupied cell (value >= occupied_threshold): the wall it hits. That cell is
//     seen when the ray meets the wall's surface at an incidence angle (between the ray and
//     the wall's normal) <= max_incidence_rad; either way the ray ends there.
// Values 0 .. occupied_threshold - 1 (free or undecided) let the ray through. The camera's own
// cell neither stops its rays nor is seen.
//
// The wall's normal at a cell comes from the occupied cells of the 5 x 5 window around it
// (wall_direction): their scatter matrix's main axis is the wall's direction, its normal the
// perpendicular. Only the line matters, not which side is in front: the ray arrives from the
// free side anyway, and a one-cell-thick wall with free space on both sides has no "inside"
// for a signed estimate (sums of offsets to free neighbours cancel there). A window whose
// occupied cells have no clear main axis (a lone cell, a pillar's solid end, the inside of a
// blob: the larger eigenvalue less than kMinAnisotropy times the smaller) has no normal, and
// such a cell counts as seen from any direction. Near a corner the window holds both walls and
// the normal tilts towards the corner's bisector, which is also where rays into a corner come
// from.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "turtlebot_recon/grid_traversal.hpp"

namespace turtlebot_recon::perception {

// The camera in the grid's frame.
struct CameraPose {
  double x_m;      // m
  double y_m;      // m
  double yaw_rad;  // rad, heading of the optical axis projected on the floor; 0 along +x
};

struct CoverageParams {
  double resolution_m;         // m, cell edge
  double origin_x_m;           // m, world x of the lower-left corner of cell (0, 0)
  double origin_y_m;           // m, world y of that corner
  double hfov_rad;             // rad, horizontal field of view, in (0, pi]
  double max_range_m;          // m, > 0: farthest wall surface at which a tag is still readable
  double max_incidence_rad;    // rad, in [0, pi/2]: most oblique view of a wall that counts
  int occupied_threshold = 65; // occupancy (0..100) >= this is a wall (map_server's 0.65)
  int rays = 0;                // rays over the field of view; 0: auto_ray_count
};

// Half-width, in cells, of the window that estimates a wall's direction (5 x 5).
constexpr int kNormalWindow = 2;
// A wall has a direction when its occupied cells spread at least this many times more (in
// variance) along their main axis than across it: a straight wall up to 3 cells thick does
// (2 vs 2/3 for a 3-thick wall in the 5 x 5 window), a 3 x 3 block does not (equal spreads).
constexpr double kMinAnisotropy = 2.0;
// More rays than this is a caller's mistake, not a finer coverage.
constexpr int kMaxRays = 1000000;
// auto_ray_count closes the gaps on walls seen up to this incidence at most (beyond it the
// rays needed grow as 1 / cos(incidence), without bound at pi/2).
constexpr double kMaxGapFreeIncidenceRad = 85.0 * M_PI / 180.0;

// Throws std::invalid_argument ("camera_coverage: ...") naming the first bad argument.
inline void validate(const CameraPose& pose, const CoverageParams& p) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("camera_coverage: " + what);
  };
  auto num = [](double v) { return std::to_string(v); };
  if (!(std::isfinite(p.resolution_m) && p.resolution_m > 0))
    fail("resolution must be a positive number of metres, got " + num(p.resolution_m));
  if (!(std::isfinite(p.origin_x_m) && std::isfinite(p.origin_y_m)))
    fail("origin must be finite, got (" + num(p.origin_x_m) + ", " + num(p.origin_y_m) + ")");
  if (!(std::isfinite(pose.x_m) && std::isfinite(pose.y_m) && std::isfinite(pose.yaw_rad)))
    fail("pose must be finite, got (" + num(pose.x_m) + ", " + num(pose.y_m) + ", " +
         num(pose.yaw_rad) + ")");
  if (!(std::isfinite(p.hfov_rad) && p.hfov_rad > 0 && p.hfov_rad <= M_PI))
    fail("hfov_rad must be in (0, pi], got " + num(p.hfov_rad));
  if (!(std::isfinite(p.max_range_m) && p.max_range_m > 0))
    fail("max_range_m must be a positive finite number of metres, got " + num(p.max_range_m));
  if (!(std::isfinite(p.max_incidence_rad) && p.max_incidence_rad >= 0 &&
        p.max_incidence_rad <= M_PI / 2))
    fail("max_incidence_rad must be in [0, pi/2], got " + num(p.max_incidence_rad));
  if (p.occupied_threshold < 1 || p.occupied_threshold > 100)
    fail("occupied_threshold must be in 1..100, got " + std::to_string(p.occupied_threshold));
  if (p.rays < 0 || p.rays > kMaxRays)
    fail("rays must be in 0.." + std::to_string(kMaxRays) + " (0: automatic), got " +
         std::to_string(p.rays));
}

// Rays enough that neighbouring rays are at most half a cell apart at range_cells and, on a
// wall they meet at incidence i <= max_incidence_rad, hit it at most one cell apart along the
// wall (so every cell of a straight face is hit): rays s = range_cells * step apart meet the
// wall s / cos(i) apart, so step = hfov / (rays - 1) <= min(0.5, cos(max_incidence)) /
// range_cells (the incidence capped at kMaxGapFreeIncidenceRad). At 60 deg both bounds agree.
inline int auto_ray_count(double hfov_rad, double range_cells, double max_incidence_rad) {
  const double spacing_cells =
      std::min(0.5, std::cos(std::min(max_incidence_rad, kMaxGapFreeIncidenceRad)));
  const double needed = std::ceil(hfov_rad * range_cells / spacing_cells) + 1.0;
  return static_cast<int>(std::min(needed, static_cast<double>(kMaxRays)));
}

// The wall through cell (row, col): its direction (rad, from +x = +col towards +y = +row,
// modulo pi) from the scatter of the occupied cells in the window around it; clear = false when
// they have no main axis (see the top of this file).
struct WallDirection {
  bool clear;
  double tangent_rad;
};

inline WallDirection wall_direction(const std::int8_t* occupancy, int rows, int cols, int row,
                                    int col, int occupied_threshold) {
  // Sums over the occupied cells of the window of their offsets (dx = d col, dy = d row).
  double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (int dy = -kNormalWindow; dy <= kNormalWindow; ++dy) {
    const int r = row + dy;
    if (r < 0 || r >= rows) continue;
    for (int dx = -kNormalWindow; dx <= kNormalWindow; ++dx) {
      const int c = col + dx;
      if (c < 0 || c >= cols) continue;
      if (occupancy[static_cast<std::size_t>(r) * cols + c] < occupied_threshold) continue;
      n += 1;
      sx += dx;
      sy += dy;
      sxx += dx * dx;
      syy += dy * dy;
      sxy += dx * dy;
    }
  }
  // Covariance [[a, b], [b, c]] and its eigenvalues (a + c) / 2 +- sqrt(((a - c) / 2)^2 + b^2).
  const double mx = sx / n, my = sy / n;
  const double a = sxx / n - mx * mx, c = syy / n - my * my, b = sxy / n - mx * my;
  const double mean = 0.5 * (a + c), radius = std::hypot(0.5 * (a - c), b);
  const double major = mean + radius, minor = mean - radius;
  if (!(major > 0) || major < kMinAnisotropy * minor) return {false, 0.0};
  // The main axis (eigenvector of `major`) makes the angle atan2(2 b, a - c) / 2 with +x.
  return {true, 0.5 * std::atan2(2.0 * b, a - c)};
}

// occupancy: ROS int8 values (< 0 unknown, 0..100), row-major (rows, cols), row 0 = smallest y.
// seen: (rows, cols); each wall cell the camera sees gets 1, every other cell keeps its value
// (so successive calls accumulate). Throws std::invalid_argument on a bad argument.
inline void camera_coverage(const std::int8_t* occupancy, int rows, int cols,
                            const CameraPose& pose, const CoverageParams& p,
                            std::uint8_t* seen) {
  validate(pose, p);
  // The camera in cell units: cell (row, col) is col <= x < col + 1, row <= y < row + 1.
  const double x0 = (pose.x_m - p.origin_x_m) / p.resolution_m;
  const double y0 = (pose.y_m - p.origin_y_m) / p.resolution_m;
  if (!(x0 >= 0 && x0 < cols && y0 >= 0 && y0 < rows)) return;  // off the grid: sees nothing
  struct Cell {
    int row, col;
    Cell operator-() const { return {-row, -col}; }
    Cell& operator+=(const Cell& o) {
      row += o.row;
      col += o.col;
      return *this;
    }
  };
  const Cell start{static_cast<int>(std::floor(y0)), static_cast<int>(std::floor(x0))};

  // Range in cells, no longer than the way to the grid's farthest corner (past it every ray
  // has left the grid; this also keeps the end cells' indices small).
  const double to_far_corner = std::hypot(std::max(x0, cols - x0), std::max(y0, rows - y0));
  const double range = std::min(p.max_range_m / p.resolution_m, to_far_corner + 1.0);
  const int rays = p.rays > 0 ? p.rays : auto_ray_count(p.hfov_rad, range, p.max_incidence_rad);
  // Seen when cos(incidence) = |sin(ray - wall direction)| >= cos(max_incidence).
  const double min_cos_incidence = std::cos(p.max_incidence_rad);

  for (int k = 0; k < rays; ++k) {
    // 1. The ray's direction within the field of view.
    const double angle =
        rays == 1 ? pose.yaw_rad : pose.yaw_rad - 0.5 * p.hfov_rad + p.hfov_rad * k / (rays - 1);
    const double x1 = x0 + range * std::cos(angle), y1 = y0 + range * std::sin(angle);
    const int d_row = static_cast<int>(std::floor(y1)) - start.row;
    const int d_col = static_cast<int>(std::floor(x1)) - start.col;
    bool camera_cell = true;
    // 2. Walk it from the camera to max range, up to the first cell that stops it.
    traverse_segment(start, x0, y0, x1, y1, d_row, d_col, Cell{1, 0}, Cell{0, 1},
                     LineEnd::kIncluded, [&](const Cell& cell) {
      if (cell.row < 0 || cell.row >= rows || cell.col < 0 || cell.col >= cols) return false;
      if (camera_cell) {  // the camera's own cell: passed, never seen
        camera_cell = false;
        return true;
      }
      const std::size_t i = static_cast<std::size_t>(cell.row) * cols + cell.col;
      const std::int8_t v = occupancy[i];
      if (v < 0) return false;                        // unknown: stops, certifies nothing
      if (v < p.occupied_threshold) return true;      // free: the ray goes on
      // 3. The first wall cell: seen if the ray meets its surface steeply enough.
      const WallDirection wall =
          wall_direction(occupancy, rows, cols, cell.row, cell.col, p.occupied_threshold);
      if (!wall.clear || std::abs(std::sin(angle - wall.tangent_rad)) >= min_cos_incidence)
        seen[i] = 1;
      return false;
    });
  }
}

}  // namespace turtlebot_recon::perception
