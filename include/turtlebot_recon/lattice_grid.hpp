// What a state-lattice search (lattice_search.hpp) reads that depends on neither its start nor
// its goal, built once and shared: the footprint's regions per heading (LatticeShapes: a
// robot, its parameters and the grid's width) and the map's products (LatticeMap: obstacles,
// distance field, graded costs of one occupancy grid). Both are immutable once built, so
// searches running at the same time may read them. LatticeCache keeps the latest of each:
// a navigator replanning on an unchanged map, or an explorer asking for the costmap and the
// reach of one map, builds them once.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "turtlebot_recon/bresenham.hpp"
#include "turtlebot_recon/costmap.hpp"
#include "turtlebot_recon/distance_field.hpp"
#include "turtlebot_recon/footprint.hpp"

namespace turtlebot_recon::planning {

struct LatticeParams {
  double resolution_m = 0.05;
  int headings = 16;                 // K: 4, 8 or 16
  double margin_m = 0.02;            // clearance of the body to obstacle edges, > 0
  double turn_margin_m = 0.01;       // clearance of the turning disc (box robots), >= 0
  double cost_weight = 1.0;          // weight of the graded cost c / 252
  double inflation_m = 0.35;         // graded band beyond the inscribed radius
  double cost_scaling_factor = 5.0;  // 1/m, decay of the graded cost
  double turn_cost_m_per_rad = 0.325;  // cruise speed / turning speed (m/s per rad/s)
  int occupied_threshold = 65;       // occupancy (0..100) >= this is an obstacle
  bool unknown_is_obstacle = false;  // unknown cells (and off the grid) are obstacles too
  double reverse_cost_factor = 0.0;  // backward moves cost this x a forward one; 0: none
};

inline auto fields(const LatticeParams& p) {
  return std::make_tuple(p.resolution_m, p.headings, p.margin_m, p.turn_margin_m, p.cost_weight,
                         p.inflation_m, p.cost_scaling_factor, p.turn_cost_m_per_rad,
                         p.occupied_threshold, p.unknown_is_obstacle, p.reverse_cost_factor);
}
inline auto fields(const Footprint& f) {
  return std::make_tuple(f.length_m, f.width_m, f.offset_x_m, f.radius_m);
}

// Throws std::invalid_argument ("plan_lattice: ...") naming the first bad parameter.
inline void validate(const LatticeParams& p) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("plan_lattice: " + what); };
  auto finite_at_least = [](double v, double lo) { return std::isfinite(v) && v >= lo; };
  if (!(std::isfinite(p.resolution_m) && p.resolution_m > 0))
    fail("resolution must be a positive number of metres");
  if (p.headings != 4 && p.headings != 8 && p.headings != 16)
    fail("headings must be 4, 8 or 16, got " + std::to_string(p.headings));
  if (!(std::isfinite(p.margin_m) && p.margin_m > 0))
    fail("margin_m must be > 0 (a body touching an obstacle's edge collides), got " +
         std::to_string(p.margin_m));
  if (!finite_at_least(p.turn_margin_m, 0)) fail("turn_margin_m must be >= 0");
  if (!finite_at_least(p.cost_weight, 0)) fail("cost_weight must be >= 0 (the heuristic needs it)");
  if (!finite_at_least(p.inflation_m, 0)) fail("inflation_m must be >= 0");
  if (!finite_at_least(p.cost_scaling_factor, 0)) fail("cost_scaling_factor must be >= 0");
  if (!finite_at_least(p.turn_cost_m_per_rad, 0)) fail("turn_cost_m_per_rad must be >= 0");
  if (!(p.reverse_cost_factor == 0.0 || (std::isfinite(p.reverse_cost_factor) && p.reverse_cost_factor >= 1.0)))
    fail("reverse_cost_factor must be 0 (no backward moves) or >= 1");
  if (p.occupied_threshold < 1 || p.occupied_threshold > 100)
    fail("occupied_threshold must be in 1..100, got " + std::to_string(p.occupied_threshold));
}

// The footprint's regions (footprint.hpp) at each lattice heading, the moves' geometry and
// costs per heading, for grids `cols` wide: a ring of `pad` cells round the grid keeps every
// region and move in memory, so no loop checks bounds. Grid cell (r, c) is padded cell
// (r + pad) * stride + c + pad.
struct LatticeShapes {
  static constexpr double kSweepStepRad = 3.0 * kPi / 180.0;

  LatticeShapes(const Footprint& footprint, const LatticeParams& params, int cols)
      : fp(footprint), p(params), cols(cols) {
    validate(fp, "plan_lattice");
    validate(p);
    headings = lattice_headings(p.headings);
    K = p.headings;
    build_regions();
    for (int k = 0; k < K; ++k) {
      const LatticeHeading& hd = headings[k];
      step[k] = hd.dr * stride + hd.dc;
      length_m[k] = std::hypot(hd.dr, hd.dc) * p.resolution_m;
      // the cells the centre enters on the move: its Bresenham line, less the start cell
      bresenham_line(0, 0, hd.dr, hd.dc, [&](int r, int c) {
        if (r != 0 || c != 0) entered[k].push_back(r * stride + c);
        return true;
      });
      per_cost_unit[k] = length_m[k] * p.cost_weight / (252.0 * entered[k].size());
      ends_cover_move[k] = !fp.round() && length_m[k] < fp.length_m;
      for (int side = 0; side < 2; ++side) {  // 0: to k + 1 (left), 1: to k - 1 (right)
        const int to = side == 0 ? (k + 1) % K : (k + K - 1) % K;
        turn_rad[k][side] = std::fabs(std::remainder(headings[to].yaw_rad - hd.yaw_rad, 2 * kPi));
      }
    }
  }

  // Built for this robot, these parameters and this grid width.
  bool built_for(const Footprint& f, const LatticeParams& q, int c) const {
    return fields(f) == fields(fp) && fields(q) == fields(p) && c == cols;
  }

  Footprint fp;
  LatticeParams p;
  int cols;
  std::vector<LatticeHeading> headings;
  int K = 16, pad = 0, stride = 0;
  std::array<GridShape, 16> pose, move;              // the body at heading k; its forward move
  GridShape turn;                                    // turning in place all the way round
  std::array<std::array<GridShape, 2>, 16> sweep;    // box robots: the partial turns
  std::array<int, 16> step{};                        // padded offset of the forward move
  std::array<double, 16> length_m{};                 // its length
  std::array<std::vector<std::int64_t>, 16> entered;  // the cells its centre enters
  std::array<double, 16> per_cost_unit{};            // L cost_weight / (252 cells entered)
  std::array<bool, 16> ends_cover_move{};            // the box's poses at both ends hold the move
  std::array<std::array<double, 2>, 16> turn_rad{};  // to k + 1, to k - 1

 private:
  // The regions: the pose and the forward move at each heading, the turn, the partial turns.
  void build_regions() {
    const double res = p.resolution_m, m = p.margin_m;
    const bool round = fp.round();
    const double x0 = fp.offset_x_m - 0.5 * fp.length_m, x1 = fp.offset_x_m + 0.5 * fp.length_m;
    const double y0 = -0.5 * fp.width_m, y1 = 0.5 * fp.width_m;
    const double rho = round ? fp.radius_m + m : m;  // a round body is a point padded
    const double corner = std::max(std::hypot(x0, y1), std::hypot(x1, y1));
    const double turn_radius = std::max(fp.radius_m, corner) + (round ? m : p.turn_margin_m);

    // The padding holds the farthest cell of any region (the turn, or the longest move's
    // farthest corner): bounded here, as the regions' offsets need the stride.
    const double longest_move = std::sqrt(5.0) * res;
    const double reach_m =
        std::max(turn_radius, std::max(std::hypot(x0, y1), std::hypot(x1 + longest_move, y1)) + rho);
    pad = static_cast<int>(std::ceil((reach_m + std::sqrt(0.5) * res) / res)) + 1;
    stride = cols + 2 * pad;

    for (int k = 0; k < K; ++k) {
      const LatticeHeading& hd = headings[k];
      const double length = std::hypot(hd.dr, hd.dc) * res;
      pose[k] = GridShape({{box_polygon(x0, x1, y0, y1), rho}}, hd.yaw_rad, res, stride);
      move[k] = GridShape({{box_polygon(x0, x1 + length, y0, y1), rho}}, hd.yaw_rad, res, stride);
    }
    if (round) {
      turn = pose[0];  // the disc itself: turning in place sweeps nothing new
      return;
    }
    std::vector<Region> spin{{{{0.0, 0.0}}, turn_radius}};
    for (const LatticeHeading& hd : headings) {  // every padded pose, turned to yaw 0's frame
      const double c = std::cos(hd.yaw_rad), s = std::sin(hd.yaw_rad);
      std::vector<Vec2> box;
      for (Vec2 v : box_polygon(x0, x1, y0, y1)) box.push_back({c * v.x - s * v.y, s * v.x + c * v.y});
      spin.push_back({box, m});
    }
    turn = GridShape(spin, 0.0, res, stride);
    // The box swept from heading k to each neighbour: its poses every <= kSweepStepRad,
    // padded by margin_m (the union misses only slivers r (1 - cos(step / 2)) < 0.3 mm deep
    // at the corners' arcs, r <= 0.3 m).
    for (int k = 0; k < K; ++k) {
      for (int side = 0; side < 2; ++side) {
        const int to = side == 0 ? (k + 1) % K : (k + K - 1) % K;
        const double delta = std::remainder(headings[to].yaw_rad - headings[k].yaw_rad, 2 * kPi);
        const int n = std::max(1, static_cast<int>(std::ceil(std::fabs(delta) / kSweepStepRad)));
        std::vector<Region> swept;
        for (int i = 0; i <= n; ++i) {
          const double a = delta * i / n, c = std::cos(a), s = std::sin(a);
          std::vector<Vec2> box;
          for (Vec2 v : box_polygon(x0, x1, y0, y1)) box.push_back({c * v.x - s * v.y, s * v.x + c * v.y});
          swept.push_back({box, m});
        }
        sweep[k][side] = GridShape(swept, headings[k].yaw_rad, res, stride);
      }
    }
  }
};

// One occupancy grid on the padded grid of `shapes`: the obstacle and known masks, the squared
// distance (cells) from every cell centre to the nearest obstacle centre, and the graded costs
// (the costmap convention for the box: 254 obstacle, 255 unknown, 253 where the nearest
// obstacle edge is nearer than the box's inscribed radius plus the margin, below that
// 252 exp(-k (d - r_in)) out to inflation_m, d measured to the obstacle's edge).
struct LatticeMap {
  // occupancy: ROS int8 values (< 0 unknown, 0..100), row-major (rows, cols), row 0 = lowest y.
  LatticeMap(const std::int8_t* occupancy, int rows, int cols,
             std::shared_ptr<const LatticeShapes> shapes_in)
      : rows(rows), cols(cols), shapes(std::move(shapes_in)),
        occupancy(occupancy, occupancy + static_cast<size_t>(rows) * cols) {
    const LatticeShapes& sh = *shapes;
    const LatticeParams& p = sh.p;
    if (cols != sh.cols) throw std::logic_error("LatticeMap: shapes built for another grid width");
    const int pad = sh.pad, stride = sh.stride, prows = rows + 2 * pad;
    n_cells = static_cast<size_t>(prows) * static_cast<size_t>(stride);
    if (n_cells * sh.K >= (size_t{1} << 31))
      throw std::invalid_argument("plan_lattice: grid too large (more than 2^31 states)");
    // 1. Obstacles; the padding is unknown space.
    obstacle.assign(n_cells, p.unknown_is_obstacle ? 1 : 0);
    known.assign(n_cells, 0);
    for (int r = 0; r < rows; ++r) {
      const std::int8_t* in = occupancy + static_cast<size_t>(r) * cols;
      const size_t i0 = static_cast<size_t>(r + pad) * stride + pad;
      for (int c = 0; c < cols; ++c) {
        known[i0 + c] = in[c] >= 0;
        obstacle[i0 + c] = in[c] >= p.occupied_threshold || (in[c] < 0 && p.unknown_is_obstacle);
      }
    }
    // 2. Squared distance (cells) from every cell centre to the nearest obstacle centre.
    d2.resize(n_cells);
    squared_distance_cells(obstacle.data(), prows, stride, d2.data());
    // 3. Graded costs, cached by squared distance (integers) as inflate() does.
    const double h = 0.5 * p.resolution_m, r_in = sh.pose[0].r_in_m();
    const double reject = sh.pose[0].reject_d2();
    const double band_m = r_in + h + p.inflation_m;
    const int band_d2 = static_cast<int>(std::ceil(square(band_m / p.resolution_m)));
    std::vector<std::uint8_t> graded(static_cast<size_t>(band_d2) + 1);
    for (int q = 0; q <= band_d2; ++q) {
      // beyond: how far the obstacle's edge (half a cell nearer than its centre) lies past r_in
      const double beyond = std::sqrt(static_cast<double>(q)) * p.resolution_m - h - r_in;
      const double value = kMaxNonObstacle * std::exp(-p.cost_scaling_factor * std::max(beyond, 0.0));
      graded[q] = q < reject                        ? kInscribedObstacle
                  : beyond > p.inflation_m + 1e-9 ? kFreeSpace
                  : static_cast<std::uint8_t>(std::clamp(std::floor(value), 0.0, 252.0));
    }
    cost.resize(n_cells);
    for (size_t i = 0; i < n_cells; ++i) {
      cost[i] = obstacle[i]  ? kLethalObstacle
                : !known[i]  ? kNoInformation
                : d2[i] <= band_d2 ? graded[static_cast<int>(d2[i])]
                                   : kFreeSpace;
    }
  }

  // Built from this grid, for these shapes.
  bool built_for(const std::int8_t* occ, int r, int c, const LatticeShapes* sh) const {
    return sh == shapes.get() && r == rows && c == cols &&
           std::memcmp(occ, occupancy.data(), occupancy.size()) == 0;
  }

  int rows, cols;
  std::shared_ptr<const LatticeShapes> shapes;
  std::vector<std::int8_t> occupancy;  // the grid it was built from (the cache's key)
  size_t n_cells = 0;                  // padded cells
  std::vector<std::uint8_t> obstacle, known, cost;
  std::vector<float> d2;               // squared distance (cells) to the nearest obstacle

 private:
  static double square(double v) { return v * v; }
};

// The latest LatticeShapes and LatticeMaps built, for reuse while the robot, its parameters
// and the map stay the same (compared in full: the map byte by byte, ~0.1 ms a megabyte).
// Thread-safe; what it hands out stays valid after it drops it.
class LatticeCache {
 public:
  static constexpr size_t kKept = 2;  // of each: e.g. two robots' or two maps' at once

  std::shared_ptr<const LatticeShapes> shapes(const Footprint& fp, const LatticeParams& p, int cols) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& s : shapes_)
        if (s->built_for(fp, p, cols)) return s;
    }
    auto built = std::make_shared<const LatticeShapes>(fp, p, cols);  // outside the lock
    std::lock_guard<std::mutex> lock(mutex_);
    keep(shapes_, built);
    return built;
  }

  std::shared_ptr<const LatticeMap> map(const std::int8_t* occupancy, int rows, int cols,
                                        const std::shared_ptr<const LatticeShapes>& shapes) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& m : maps_)
        if (m->built_for(occupancy, rows, cols, shapes.get())) return m;
    }
    auto built = std::make_shared<const LatticeMap>(occupancy, rows, cols, shapes);
    std::lock_guard<std::mutex> lock(mutex_);
    keep(maps_, built);
    return built;
  }

 private:
  template <class T>
  static void keep(std::vector<std::shared_ptr<const T>>& kept, std::shared_ptr<const T> item) {
    kept.insert(kept.begin(), std::move(item));  // newest first
    if (kept.size() > kKept) kept.pop_back();
  }

  std::mutex mutex_;
  std::vector<std::shared_ptr<const LatticeShapes>> shapes_;
  std::vector<std::shared_ptr<const LatticeMap>> maps_;
};

}  // namespace turtlebot_recon::planning
