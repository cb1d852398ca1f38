// Inflated costmap (the move_base / Nav2 convention) and queries on it.
//
// Cost values: 0 free ... 252 graded, 253 INSCRIBED (the robot's centre here puts its body
// on an obstacle), 254 LETHAL (an obstacle), 255 NO_INFORMATION (unknown). The graded band
// follows Nav2's inflation layer: cost = (INSCRIBED - 1) * exp(-k (d - r_inscribed)).
// Seed 001 thresholded a brushfire distance instead; this keeps its "accessible cell"
// notion (cost below INSCRIBED) and adds a gradient that keeps paths off walls.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "turtlebot_recon/distance_field.hpp"

namespace turtlebot_recon::planning {

constexpr std::uint8_t kFreeSpace = 0;
constexpr std::uint8_t kMaxNonObstacle = 252;
constexpr std::uint8_t kInscribedObstacle = 253;
constexpr std::uint8_t kLethalObstacle = 254;
constexpr std::uint8_t kNoInformation = 255;

struct Cell {
  int row;
  int col;
};

inline std::string to_string(Cell c) {
  return "(" + std::to_string(c.row) + ", " + std::to_string(c.col) + ")";
}

struct InflationParams {
  double resolution_m = 0.05;
  double inscribed_radius_m = 0.105;
  double inflation_radius_m = 0.455;
  double cost_scaling_factor = 5.0;  // 1/m
  int occupied_threshold = 65;       // occupancy >= this is an obstacle (ROS 0..100)
  bool unknown_is_obstacle = false;  // unknown (-1) cells: LETHAL instead of NO_INFORMATION
};

// Throws std::invalid_argument naming the first bad parameter.
inline void validate(const InflationParams& p) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("inflate: " + what); };
  if (!(std::isfinite(p.resolution_m) && p.resolution_m > 0))
    fail("resolution must be a positive number of metres, got " + std::to_string(p.resolution_m));
  if (!(std::isfinite(p.inscribed_radius_m) && p.inscribed_radius_m >= 0))
    fail("inscribed_radius_m must be >= 0, got " + std::to_string(p.inscribed_radius_m));
  if (!(std::isfinite(p.inflation_radius_m) && p.inflation_radius_m >= p.inscribed_radius_m))
    fail("inflation_radius_m (" + std::to_string(p.inflation_radius_m) +
         ") must be >= inscribed_radius_m (" + std::to_string(p.inscribed_radius_m) + ")");
  if (p.inflation_radius_m / p.resolution_m > 4096.0)
    fail("inflation_radius_m spans more than 4096 cells; raise the resolution");
  if (!(std::isfinite(p.cost_scaling_factor) && p.cost_scaling_factor >= 0))
    fail("cost_scaling_factor must be >= 0, got " + std::to_string(p.cost_scaling_factor));
  if (p.occupied_threshold < 1 || p.occupied_threshold > 100)
    fail("occupied_threshold must be in 1..100, got " + std::to_string(p.occupied_threshold));
}

// Cost of a cell whose nearest obstacle is sqrt(d2) cells away (Nav2's computeCost).
inline std::uint8_t inflation_cost(double d2_cells, const InflationParams& p) {
  constexpr double kEps = 1e-9;  // metres: radii that are multiples of the resolution count
  if (d2_cells == 0.0) return kLethalObstacle;
  const double d = std::sqrt(d2_cells) * p.resolution_m;
  if (d <= p.inscribed_radius_m + kEps) return kInscribedObstacle;
  if (d > p.inflation_radius_m + kEps) return kFreeSpace;
  const double factor = std::exp(-p.cost_scaling_factor * (d - p.inscribed_radius_m));
  return static_cast<std::uint8_t>(std::floor((kInscribedObstacle - 1) * factor));
}

// occupancy: ROS int8 values (< 0 unknown, 0..100), row-major (rows, cols).
// cost_out: rows * cols bytes; it also serves as the obstacle mask while the distances
// are computed, so the only scratch buffer is the float distance field.
inline void inflate(const std::int8_t* occupancy, int rows, int cols, const InflationParams& p,
                    std::uint8_t* cost_out) {
  validate(p);
  const size_t n = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  auto is_obstacle = [&p](std::int8_t v) {
    return v >= p.occupied_threshold || (v < 0 && p.unknown_is_obstacle);
  };

  // Step 1: obstacle cells (into cost_out, used as the mask).
  for (size_t i = 0; i < n; ++i) cost_out[i] = is_obstacle(occupancy[i]) ? 1 : 0;

  // Step 2: exact squared distance (cells) from every cell to the nearest obstacle.
  std::vector<float> d2(n);
  squared_distance_cells(cost_out, rows, cols, d2.data());

  // Step 3: cost from distance. Squared cell distances are integers, so the costs inside
  // the inflation radius are cached by d2 (costmap_2d's cached_costs_).
  const double radius_cells = p.inflation_radius_m / p.resolution_m;
  const int max_d2 = static_cast<int>(std::floor(radius_cells * radius_cells + 1e-6));
  std::vector<std::uint8_t> cached(static_cast<size_t>(max_d2) + 1);
  for (int k = 0; k <= max_d2; ++k) cached[k] = inflation_cost(k, p);
  for (size_t i = 0; i < n; ++i) {
    std::uint8_t c = d2[i] <= static_cast<float>(max_d2) ? cached[static_cast<int>(d2[i])]
                                                          : kFreeSpace;
    if (occupancy[i] < 0 && !p.unknown_is_obstacle) c = kNoInformation;
    cost_out[i] = c;
  }
}

// Seed 001's "nearest accessible point": the cell nearest to `target` (Euclidean, ties to
// the smaller row, then the smaller column) whose cost is <= max_cost and known, within
// max_radius_m. `target` may lie outside the grid. Returns false when there is none.
inline bool nearest_accessible(const std::uint8_t* cost, int rows, int cols, Cell target,
                               int max_cost, double max_radius_m, double resolution_m,
                               Cell* found) {
  const double radius_cells = max_radius_m / resolution_m;
  const long long max_d2 = static_cast<long long>(std::floor(radius_cells * radius_cells + 1e-6));
  // Rings beyond the farthest grid corner hold no cell of the grid.
  const long long farthest =
      std::max({std::llabs(target.row), std::llabs(target.row - rows + 1LL),
                std::llabs(target.col), std::llabs(target.col - cols + 1LL)});
  const int max_ring = static_cast<int>(
      std::min<double>(std::floor(radius_cells + 1e-9), static_cast<double>(farthest)));
  long long best_d2 = std::numeric_limits<long long>::max();
  Cell best{0, 0};
  auto consider = [&](int r, int c) {
    if (r < 0 || r >= rows || c < 0 || c >= cols) return;
    const std::uint8_t v = cost[static_cast<size_t>(r) * cols + c];
    if (v == kNoInformation || v > max_cost) return;
    const long long dr = r - target.row, dc = c - target.col, d2 = dr * dr + dc * dc;
    if (d2 > max_d2) return;
    if (d2 < best_d2 || (d2 == best_d2 && (r < best.row || (r == best.row && c < best.col)))) {
      best_d2 = d2;
      best = {r, c};
    }
  };
  // Square rings of growing Chebyshev radius k: every cell of ring k is at least k away,
  // so the search stops once k^2 exceeds the best squared distance found so far.
  for (int k = 0; k <= max_ring && static_cast<long long>(k) * k <= best_d2; ++k) {
    if (k == 0) {
      consider(target.row, target.col);
      continue;
    }
    for (int i = -k; i <= k; ++i) {
      consider(target.row - k, target.col + i);  // bottom and top edges
      consider(target.row + k, target.col + i);
    }
    for (int i = -k + 1; i <= k - 1; ++i) {
      consider(target.row + i, target.col - k);  // left and right edges
      consider(target.row + i, target.col + k);
    }
  }
  if (best_d2 == std::numeric_limits<long long>::max()) return false;
  *found = best;
  return true;
}

}  // namespace turtlebot_recon::planning
