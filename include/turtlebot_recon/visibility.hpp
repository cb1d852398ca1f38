// Information gain of a viewpoint: the unknown cells a 2-D lidar at that cell could reveal.
// (visible_cells, at the end, walks the same rays for the evaluator's line of sight.)
//
// For each query cell, `beams` rays at angles 2 pi k / beams (k = 0 .. beams - 1; angle 0
// along +col = +x, pi / 2 along +row = +y) are walked cell by cell with Bresenham's line
// algorithm towards the cell (round(R sin a), round(R cos a)) away from the query cell,
// R = radius_cells. A ray stops
//   - at the first cell farther than R from the query cell (centre to centre), so the
//     footprint is the disc of radius R;
//   - when it leaves the grid;
//   - on an occupied cell (known, value > free_threshold): a wall hides what is behind it.
// Unknown cells (value < 0) do not stop a ray: the lidar would see into them, which is the
// point of going there. The query cell itself never stops its rays (the sensor sits there).
// Every unknown cell a ray passes over counts once per query, however many rays cross it:
// a stamp per cell of the (2 floor(R) + 1)^2 window around the query cell, equal to the
// query's number when the cell has been counted, so the window is cleared only once.
//
// Bresenham on the ray from the origin: each step moves one cell along the major axis and
// maybe one along the minor axis, both away from the origin, so the squared distance grows
// at every step and the first cell outside the disc ends the ray.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "turtlebot_recon/bresenham.hpp"

namespace turtlebot_recon::exploration {

struct VisibilityParams {
  double radius_cells = 70.0;  // sensor range in cells (range_m / resolution)
  int beams = 180;             // rays per query, evenly spread over the full circle
  int free_threshold = 25;     // known values above this are occupied and block rays
};

// Throws std::invalid_argument ("<who>: ...") naming the first bad parameter.
inline void validate(const VisibilityParams& p, const char* who = "visible_unknown") {
  auto fail = [who](const std::string& what) {
    throw std::invalid_argument(std::string(who) + ": " + what);
  };
  if (!(std::isfinite(p.radius_cells) && p.radius_cells >= 0))
    fail("radius_cells must be a finite number >= 0, got " + std::to_string(p.radius_cells));
  if (p.radius_cells > 4096.0) fail("radius_cells must be <= 4096 cells");
  if (p.beams < 1) fail("beams must be >= 1, got " + std::to_string(p.beams));
  if (p.free_threshold < 0 || p.free_threshold > 100)
    fail("free_threshold must be in 0..100, got " + std::to_string(p.free_threshold));
}

// Ray end points relative to the query cell, (drow, dcol), duplicates removed (at small
// radii several beams end on the same cell and would walk the same line).
inline std::vector<std::pair<int, int>> beam_ends(const VisibilityParams& p) {
  std::vector<std::pair<int, int>> ends;
  ends.reserve(static_cast<size_t>(p.beams));
  for (int k = 0; k < p.beams; ++k) {
    const double angle = 2.0 * M_PI * k / p.beams;
    ends.emplace_back(static_cast<int>(std::floor(p.radius_cells * std::sin(angle) + 0.5)),
                      static_cast<int>(std::floor(p.radius_cells * std::cos(angle) + 0.5)));
  }
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
  return ends;
}

// occupancy: ROS int8 values (< 0 unknown, 0..100), row-major (rows, cols).
// cells: n query cells as (row, col) pairs, cells[2 i] = row; each must lie on the grid.
// counts_out: n counts of distinct unknown cells visible from each query cell.
inline void visible_unknown(const std::int8_t* occupancy, int rows, int cols,
                            const std::int32_t* cells, size_t n, const VisibilityParams& p,
                            std::int32_t* counts_out) {
  validate(p);
  for (size_t i = 0; i < n; ++i) {
    const int r = cells[2 * i], c = cells[2 * i + 1];
    if (r < 0 || r >= rows || c < 0 || c >= cols)
      throw std::invalid_argument("visible_unknown: query cell " + std::to_string(i) + " (" +
                                  std::to_string(r) + ", " + std::to_string(c) +
                                  ") is outside the " + std::to_string(rows) + " x " +
                                  std::to_string(cols) + " grid");
  }
  const std::vector<std::pair<int, int>> ends = beam_ends(p);
  const double r2_max = p.radius_cells * p.radius_cells;
  const int half = static_cast<int>(std::floor(p.radius_cells));  // window half-width
  const int side = 2 * half + 1;
  std::vector<std::uint32_t> stamp(static_cast<size_t>(side) * side, 0);

  for (size_t i = 0; i < n; ++i) {
    const int r0 = cells[2 * i], c0 = cells[2 * i + 1];
    const std::uint32_t query = static_cast<std::uint32_t>(i) + 1;  // 0 = never counted
    std::int32_t count = 0;
    for (const auto& [end_r, end_c] : ends) {
      bresenham_line(0, 0, end_r, end_c, [&](int dr, int dc) {
        // 1. Range: the first cell beyond the disc ends the ray.
        if (static_cast<double>(dr * dr + dc * dc) > r2_max) return false;
        // 2. The grid's edge ends the ray.
        const int r = r0 + dr, c = c0 + dc;
        if (r < 0 || r >= rows || c < 0 || c >= cols) return false;
        const std::int8_t v = occupancy[static_cast<size_t>(r) * cols + c];
        // 3. An unknown cell is counted once per query and lets the ray through.
        if (v < 0) {
          std::uint32_t& s = stamp[static_cast<size_t>(dr + half) * side + (dc + half)];
          if (s != query) {
            s = query;
            ++count;
          }
          return true;
        }
        // 4. An occupied cell (other than the sensor's own) ends the ray.
        return v <= p.free_threshold || (dr == 0 && dc == 0);
      });
    }
    counts_out[i] = count;
  }
}

// Line of sight from a set of viewpoints (evaluation: the free space a lidar can see, DESIGN §6).
//
// blocking: row-major (rows, cols) mask, != 0 where a cell stops rays (a wall).
// points: n viewpoints as (row, col) pairs, points[2 i] = row; each must lie on the grid.
// seen_out: (rows, cols), set to true on every cell that some ray of some viewpoint reaches,
//   false elsewhere.
// The rays are those of visible_unknown (same beam_ends, same Bresenham walk from (0, 0), same
// disc of radius radius_cells), and a ray stops at the first blocking cell, beyond the disc or at the grid's
// edge. A blocking cell is never marked seen: a lidar sees a wall's surface, but the evaluator
// only needs the free cells. A viewpoint's own cell never stops its rays (the sensor sits
// there) and is seen unless it is blocking.
inline void visible_cells(const std::uint8_t* blocking, int rows, int cols,
                          const std::int32_t* points, size_t n, double radius_cells, int beams,
                          bool* seen_out) {
  const VisibilityParams p{radius_cells, beams};
  validate(p, "visible_cells");
  for (size_t i = 0; i < n; ++i) {
    const int r = points[2 * i], c = points[2 * i + 1];
    if (r < 0 || r >= rows || c < 0 || c >= cols)
      throw std::invalid_argument("visible_cells: point " + std::to_string(i) + " (" +
                                  std::to_string(r) + ", " + std::to_string(c) +
                                  ") is outside the " + std::to_string(rows) + " x " +
                                  std::to_string(cols) + " grid");
  }
  std::fill(seen_out, seen_out + static_cast<size_t>(rows) * cols, false);
  const std::vector<std::pair<int, int>> ends = beam_ends(p);
  const double r2_max = p.radius_cells * p.radius_cells;

  for (size_t i = 0; i < n; ++i) {
    const int r0 = points[2 * i], c0 = points[2 * i + 1];
    for (const auto& [end_r, end_c] : ends) {
      bresenham_line(0, 0, end_r, end_c, [&](int dr, int dc) {
        // 1. Range: the first cell beyond the disc ends the ray.
        if (static_cast<double>(dr * dr + dc * dc) > r2_max) return false;
        // 2. The grid's edge ends the ray.
        const int r = r0 + dr, c = c0 + dc;
        if (r < 0 || r >= rows || c < 0 || c >= cols) return false;
        const size_t k = static_cast<size_t>(r) * cols + c;
        // 3. A blocking cell (other than the sensor's own) ends the ray, unseen.
        if (blocking[k] != 0) return dr == 0 && dc == 0;
        seen_out[k] = true;
        return true;
      });
    }
  }
}

}  // namespace turtlebot_recon::exploration
