// Log-odds occupancy grid filled by Bresenham ray casting (seed 001's direct cell marking,
// made probabilistic), with seed 001's bumper marks and visit-count map.
//
// Cells are in nav_msgs/OccupancyGrid order: row-major, row 0 = smallest y; cell (r, c)
// covers x in [origin_x + c*res, origin_x + (c+1)*res) and likewise y with r. Cell edges
// are fixed in the world when the grid grows: every position is kept as a "global" cell
// index (relative to the constructor's origin) and the grid is a window [offset, offset +
// size) onto it, so growing only moves the window by whole cells.
//
// A scan updates each cell at most once (OctoMap's rule): one hit where any beam returned,
// else one miss where any ray passed; see insert_scan.
//
// Thread safety: every public method locks the grid's mutex, so a scan thread and a map
// publishing thread may share one grid (the Python binding releases the GIL in insert_scan).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

namespace turtlebot_recon {

struct GridSettings {
  double resolution = 0.05;     // m, cell edge
  double width_m = 10.0;        // initial extent along x
  double height_m = 10.0;       // initial extent along y
  double origin_x = -5.0;       // m, world x of the lower-left corner of cell (0, 0)
  double origin_y = -5.0;       // m
  double p_hit = 0.7;           // occupancy probability a hit votes for, in (0.5, 1)
  double p_miss = 0.4;          // occupancy probability a miss votes for, in (0, 0.5)
  double p_min = 0.12;          // clamp: log-odds never below l(p_min) ...
  double p_max = 0.97;          // ... nor above l(p_max), so a cell can change its mind
  double grow_margin_m = 2.0;   // extra room added on each side that a scan leaves
};

// One laser scan in the map frame (REP-117 values: NaN, -inf too close, +inf no return).
struct Scan {
  double sensor_x = 0.0, sensor_y = 0.0, sensor_yaw = 0.0;  // m, m, rad
  const float* ranges = nullptr;  // m, `count` beams; beam i at yaw + angle_min + i*increment
  std::size_t count = 0;
  double angle_min = 0.0, angle_increment = 0.0;  // rad
  double range_min = 0.0, range_max = 0.0;        // m
  double no_return_clear_m = 0.0;  // a beam with no return clears this far (<= range_max); 0: not at all
  double range_cap_m = 0.0;        // valid returns beyond this only clear up to it; 0: no cap
};

// How the beams of one scan were classified.
struct ScanStats {
  int valid = 0;      // ray of misses + a hit at the return
  int no_return = 0;  // +inf, 0.0 (LDS-01 driver) or > range_max: cleared up to no_return_clear_m
  int capped = 0;     // valid but > range_cap_m: cleared up to range_cap_m, no hit
  int too_close = 0;  // -inf or below range_min: ignored
  int nan = 0;        // NaN: ignored
  int total = 0;      // beams in the scan
};

// A read-only look at the cells, handed out under the grid's lock (see OccupancyGrid::read).
struct GridView {
  int rows;
  int cols;
  const float* logodds;         // rows*cols, NaN = never observed
  const std::int32_t* visits;   // rows*cols
};

// Log-odds of a probability: l(p) = log(p / (1 - p)).
inline double log_odds(double p) { return std::log(p / (1.0 - p)); }

// ROS occupancy value of one cell: -1 unknown, else round(100 p), p = 1 - 1/(1 + exp(l)).
inline std::int8_t occupancy_value(float logodds) {
  if (std::isnan(logodds)) return -1;
  const double p = 1.0 - 1.0 / (1.0 + std::exp(static_cast<double>(logodds)));
  return static_cast<std::int8_t>(std::lround(100.0 * p));
}

class OccupancyGrid {
 public:
  // Throws std::invalid_argument when a setting is out of range.
  explicit OccupancyGrid(const GridSettings& settings);

  // Ray-casts every beam from the sensor to its end point: the end cell of a valid return is
  // a hit; the cells the beam passes through before it (the sensor cell included, every
  // cell the segment touches: grid_traversal.hpp) are crossed, and so are those of a clearing
  // ray (no return, capped) up to its end cell or the first cell believed occupied (a dropout
  // reads as no return), which it leaves alone. Updates go
  // by cell, not by beam (OctoMap's insertPointCloud rule): within one scan every cell is
  // updated at most once, one hit for a cell that is the hit of any valid beam (even if
  // other beams cross it: occupied wins), one miss for every other crossed cell however many
  // beams cross it. Grows the grid once first if the rays leave it. Throws
  // std::invalid_argument on a non-finite pose or bad range limits, std::length_error if
  // the grid would grow past ~134 M cells.
  ScanStats insert_scan(const Scan& scan);

  // Seed 001's bumper mark: `cells` cells set to the clamp maximum along a line tangent to
  // the body at the contact point (distance robot_radius_m + res/2 in direction
  // yaw + bumper_angle_rad), centred on it, one cell apart along the line's main axis. The
  // marks stay: later scans' beams pass over them (the obstacle is below the lidar's plane).
  void mark_bumper(double x, double y, double yaw, double bumper_angle_rad, double robot_radius_m,
                   int cells);

  // Seed 001's visit map: counts the cell holding (x, y) when speed_mps >= min_speed_mps and
  // it is not the cell counted last. Returns whether it counted.
  bool add_visit(double x, double y, double speed_mps, double min_speed_mps);

  // The robot stands on the disc of radius_m around (x, y): its cells that are still unknown
  // (under the body, inside the lidar's minimum range) become free (p_min: it stands there).
  // Known cells keep their value. Returns the number of cells changed.
  int free_unknown_disc(double x, double y, double radius_m);

  // Every cell unknown, every visit count 0; size and origin stay.
  void clear();

  // A prior map (a saved one): every cell's log-odds from `logodds` (rows x cols, row-major,
  // the grid's own shape; NaN = unknown), clamped to [log-odds(p_min), log-odds(p_max)] so
  // that scans can still change it. Throws std::invalid_argument on another shape.
  void set_logodds(const float* logodds, int rows, int cols);

  // Calls fn(const GridView&) with the grid locked: copy what you need inside fn.
  template <class Fn>
  void read(Fn&& fn) const {
    std::lock_guard<std::mutex> lock(mutex_);
    fn(GridView{rows_, cols_, logodds_.data(), visits_.data()});
  }

  // (row, col) of the cell holding (x, y) in the current window; may lie outside it.
  std::pair<int, int> cell_of(double x, double y) const;

  double resolution() const { return settings_.resolution; }
  double origin_x() const;
  double origin_y() const;
  int rows() const;
  int cols() const;
  int grow_count() const;
  const GridSettings& settings() const { return settings_; }

 private:
  struct Cell {  // global cell index: fixed in the world, unchanged by growth
    int row;
    int col;
    bool operator==(const Cell& o) const { return row == o.row && col == o.col; }
    bool operator!=(const Cell& o) const { return !(*this == o); }
  };
  struct Ray {  // one beam to trace: global end cell, its end point (global cell units),
    Cell end;   // and whether it ends in a hit
    double x, y;
    bool hit;
  };
  struct Box {  // inclusive bounds in global cells
    int row_min, row_max, col_min, col_max;
    void include(const Cell& c);
  };

  // (x, y) m -> global cell units: cell (row, col) is col <= x' < col + 1, row <= y' < row + 1.
  double grid_x(double x) const { return (x - settings_.origin_x) / settings_.resolution; }
  double grid_y(double y) const { return (y - settings_.origin_y) / settings_.resolution; }
  Cell global_cell(double x, double y) const;  // throws on non-finite / absurd coordinates
  std::size_t index(const Cell& c) const {
    return static_cast<std::size_t>(c.row - row_offset_) * cols_ + (c.col - col_offset_);
  }
  void grow_to_cover(const Box& box);
  std::uint32_t next_scan_stamp();
  void trace_misses(const Cell& from, double x0, double y0, const Ray& ray, std::uint32_t stamp);
  void update(float& logodds, float delta) const;

  GridSettings settings_;
  float l_hit_, l_miss_, l_min_, l_max_;  // log-odds of p_hit, p_miss, p_min, p_max
  int margin_cells_;                      // grow_margin_m in cells

  int rows_ = 0, cols_ = 0;
  int row_offset_ = 0, col_offset_ = 0;  // global cell of local (0, 0)
  std::vector<float> logodds_;           // NaN = never observed
  std::vector<std::int32_t> visits_;
  // 1 where a bumper press marked the cell: something below the lidar's plane. Its beams pass
  // over such a cell without a miss, so the mark stays (the lidar cannot see what the bumper felt).
  std::vector<std::uint8_t> bumped_;
  // Per cell, the stamp of the last scan that updated it (0: none since the last growth):
  // a cell whose stamp is the current scan's has had its one update of this scan.
  std::vector<std::uint32_t> scan_stamps_;
  std::uint32_t scan_stamp_ = 0;         // the last scan's stamp; never 0 once a scan ran
  int grow_count_ = 0;

  bool has_last_visit_ = false;
  Cell last_visit_{0, 0};

  std::vector<Ray> rays_;  // per-scan scratch, reused so a scan allocates nothing
  mutable std::mutex mutex_;
};

}  // namespace turtlebot_recon
