#include "turtlebot_recon/occupancy_grid.hpp"

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "turtlebot_recon/grid_traversal.hpp"

namespace turtlebot_recon {

namespace {

// A grid past this many cells (12 bytes each: ~1.5 GiB) is a unit mistake, not a map.
constexpr std::int64_t kMaxCells = std::int64_t{1} << 27;
// Global cell indices stay far from int overflow, with room for the growth margin.
constexpr double kMaxCellIndex = 1e9;

void check(bool ok, const char* message) {
  if (!ok) throw std::invalid_argument(message);
}

void check(bool ok, const std::string& message) {  // construction only: not on a hot path
  if (!ok) throw std::invalid_argument(message);
}

int cells_for(double length_m, double resolution) {
  // A tolerance so that 10 m / 0.05 m is 200 cells, not 201.
  return std::max(1, static_cast<int>(std::ceil(length_m / resolution - 1e-6)));
}

}  // namespace

void OccupancyGrid::Box::include(const Cell& c) {
  row_min = std::min(row_min, c.row);
  row_max = std::max(row_max, c.row);
  col_min = std::min(col_min, c.col);
  col_max = std::max(col_max, c.col);
}

OccupancyGrid::OccupancyGrid(const GridSettings& s) : settings_(s) {
  check(std::isfinite(s.resolution) && s.resolution > 0,
        "OccupancyGrid: resolution must be > 0 m, got " + std::to_string(s.resolution));
  check(std::isfinite(s.width_m) && s.width_m > 0 && std::isfinite(s.height_m) && s.height_m > 0,
        "OccupancyGrid: width_m and height_m must be > 0");
  check(std::isfinite(s.origin_x) && std::isfinite(s.origin_y),
        "OccupancyGrid: origin_x and origin_y must be finite");
  check(s.p_hit > 0.5 && s.p_hit < 1.0,
        "OccupancyGrid: p_hit must be in (0.5, 1), got " + std::to_string(s.p_hit));
  check(s.p_miss > 0.0 && s.p_miss < 0.5,
        "OccupancyGrid: p_miss must be in (0, 0.5), got " + std::to_string(s.p_miss));
  check(s.p_min > 0.0 && s.p_min < s.p_max && s.p_max < 1.0,
        "OccupancyGrid: need 0 < p_min < p_max < 1, got p_min=" + std::to_string(s.p_min) +
            ", p_max=" + std::to_string(s.p_max));
  check(std::isfinite(s.grow_margin_m) && s.grow_margin_m >= 0 &&
            s.grow_margin_m / s.resolution < 1e6,
        "OccupancyGrid: grow_margin_m must be >= 0 m and under a million cells");
  l_hit_ = static_cast<float>(log_odds(s.p_hit));
  l_miss_ = static_cast<float>(log_odds(s.p_miss));
  l_min_ = static_cast<float>(log_odds(s.p_min));
  l_max_ = static_cast<float>(log_odds(s.p_max));
  margin_cells_ = static_cast<int>(std::ceil(s.grow_margin_m / s.resolution - 1e-6));

  rows_ = cells_for(s.height_m, s.resolution);
  cols_ = cells_for(s.width_m, s.resolution);
  check(static_cast<std::int64_t>(rows_) * cols_ <= kMaxCells,
        "OccupancyGrid: width_m x height_m at this resolution is too many cells");
  logodds_.assign(static_cast<std::size_t>(rows_) * cols_, std::numeric_limits<float>::quiet_NaN());
  visits_.assign(logodds_.size(), 0);
  bumped_.assign(logodds_.size(), 0);
  scan_stamps_.assign(logodds_.size(), 0);
}

// ---------------------------------------------------------------------------------------
// Scan insertion: classify → grow → hits → misses, each cell updated at most once per scan.

ScanStats OccupancyGrid::insert_scan(const Scan& scan) {
  check(std::isfinite(scan.sensor_x) && std::isfinite(scan.sensor_y) &&
            std::isfinite(scan.sensor_yaw),
        "insert_scan: sensor pose must be finite");
  check(std::isfinite(scan.angle_min) && std::isfinite(scan.angle_increment),
        "insert_scan: angle_min and angle_increment must be finite");
  check(scan.range_min >= 0 && std::isfinite(scan.range_max) && scan.range_max > scan.range_min,
        "insert_scan: need 0 <= range_min < range_max < inf");
  std::lock_guard<std::mutex> lock(mutex_);

  ScanStats stats;
  stats.total = static_cast<int>(scan.count);
  const Cell sensor = global_cell(scan.sensor_x, scan.sensor_y);
  Box box{sensor.row, sensor.row, sensor.col, sensor.col};
  const double no_return_reach = std::min(scan.no_return_clear_m, scan.range_max);

  // 1. Classify every beam (REP-117 and real drivers) and find where its ray ends.
  rays_.clear();
  for (std::size_t i = 0; i < scan.count; ++i) {
    const double r = scan.ranges[i];
    double reach;  // m along the beam
    bool hit;
    if (std::isnan(r)) {
      ++stats.nan;
      continue;
    } else if (r == 0.0 || r > scan.range_max) {  // +inf, LDS-01's 0.0, beyond range
      ++stats.no_return;
      if (!(no_return_reach > 0)) continue;
      reach = no_return_reach;
      hit = false;
    } else if (r < scan.range_min) {  // -inf, too close (or negative: nonsense)
      ++stats.too_close;
      continue;
    } else if (scan.range_cap_m > 0 && r > scan.range_cap_m) {
      ++stats.capped;
      reach = scan.range_cap_m;
      hit = false;
    } else {
      ++stats.valid;
      // The return is on the obstacle's surface: the solid side lies beyond it. Placing the
      // hit half a cell further along the beam attributes it to the cell behind the surface,
      // so range noise below half a cell never marks the free cell in front of a wall
      // occupied (with the hit at the raw range, a wall on a cell boundary puts half the
      // returns in front of it, and one hit outweighs one miss).
      reach = r + 0.5 * settings_.resolution;
      hit = true;
    }
    const double angle = scan.sensor_yaw + scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    const double x = scan.sensor_x + reach * std::cos(angle), y = scan.sensor_y + reach * std::sin(angle);
    const Cell end = global_cell(x, y);
    box.include(end);
    rays_.push_back({end, grid_x(x), grid_y(y), hit});
  }

  // 2. Grow once so that every ray fits (a scan with nothing to trace writes nothing).
  if (rays_.empty()) return stats;
  grow_to_cover(box);

  // 3. One hit on every hit cell, stamped so that no ray of this scan clears it and no
  //    second beam ending there hits it again (occupied wins).
  const std::uint32_t stamp = next_scan_stamp();
  for (const Ray& ray : rays_) {
    if (!ray.hit) continue;
    const std::size_t i = index(ray.end);
    if (scan_stamps_[i] == stamp) continue;
    scan_stamps_[i] = stamp;
    update(logodds_[i], l_hit_);
  }

  // 4. One miss on every other cell that any ray crosses.
  const double sx = grid_x(scan.sensor_x), sy = grid_y(scan.sensor_y);
  for (const Ray& ray : rays_) trace_misses(sensor, sx, sy, ray, stamp);
  return stats;
}

// A stamp no cell holds yet. After 2^32 - 1 scans the counter wraps: every stamp is reset.
std::uint32_t OccupancyGrid::next_scan_stamp() {
  if (++scan_stamp_ == 0) {
    std::fill(scan_stamps_.begin(), scan_stamps_.end(), 0);
    scan_stamp_ = 1;
  }
  return scan_stamp_;
}

// Bayes update in log-odds: add the measurement's log-odds (an unknown cell starts at 0,
// p = 0.5), clamped so that a cell can still change its mind.
inline void OccupancyGrid::update(float& l, float delta) const {
  const float prior = std::isnan(l) ? 0.0f : l;
  l = std::clamp(prior + delta, l_min_, l_max_);
}

// The beam from the sensor point (x0, y0) in cell `from` to its end point, cell by cell through
// every cell it passes (grid_traversal.hpp): a miss on every cell before the end cell (the
// sensor cell included) that this scan has not updated yet (a hit cell, or one an earlier ray
// crossed), stamping it. The end cell is left alone (its hit, if any, is done). A clearing
// ray (no return, capped) stops at the first cell the map believes occupied (log-odds > 0,
// this scan's hits included): a no-return reading is also what a dropout gives, and a dropout
// at a wall must not clear the unknown space behind it. Walks one offset into the log-odds
// and stamp buffers (a row step is +-cols_ cells).
void OccupancyGrid::trace_misses(const Cell& from, double x0, double y0, const Ray& ray,
                                 std::uint32_t stamp) {
  float* const logodds = logodds_.data();
  std::uint32_t* const stamps = scan_stamps_.data();
  const std::uint8_t* const bumped = bumped_.data();
  const auto start = static_cast<std::ptrdiff_t>(index(from));
  traverse_segment(start, x0, y0, ray.x, ray.y, ray.end.row - from.row, ray.end.col - from.col,
                   std::ptrdiff_t{cols_}, std::ptrdiff_t{1}, LineEnd::kExcluded, [&](std::ptrdiff_t i) {
                   if (bumped[i]) return true;  // below the scan plane: the beam passes over it
                   if (!ray.hit && logodds[i] > 0.0f) return false;  // a clearing ray: see above
                   if (stamps[i] != stamp) {
                     stamps[i] = stamp;
                     update(logodds[i], l_miss_);
                   }
                   return true;
                 });
}

// ---------------------------------------------------------------------------------------
// Bumper marks and visits.

void OccupancyGrid::mark_bumper(double x, double y, double yaw, double bumper_angle_rad,
                                double robot_radius_m, int cells) {
  check(std::isfinite(x) && std::isfinite(y) && std::isfinite(yaw) && std::isfinite(bumper_angle_rad),
        "mark_bumper: pose and bumper angle must be finite");
  check(std::isfinite(robot_radius_m) && robot_radius_m >= 0, "mark_bumper: robot_radius_m must be >= 0");
  check(cells >= 1 && cells <= 10000, "mark_bumper: cells must be in [1, 10000]");
  std::lock_guard<std::mutex> lock(mutex_);

  // Contact point just outside the body, and the body's tangent there.
  const double theta = yaw + bumper_angle_rad;
  const double reach = robot_radius_m + 0.5 * settings_.resolution;
  const Cell contact = global_cell(x + reach * std::cos(theta), y + reach * std::sin(theta));
  const double tx = -std::sin(theta), ty = std::cos(theta);
  const double main_axis = std::max(std::abs(tx), std::abs(ty));  // one cell per step along it

  std::vector<Cell> marks;
  marks.reserve(cells);
  Box box{contact.row, contact.row, contact.col, contact.col};
  for (int k = 0; k < cells; ++k) {
    const double offset = k - cells / 2;  // -2..2 for five cells
    const Cell c{contact.row + static_cast<int>(std::lround(offset * ty / main_axis)),
                 contact.col + static_cast<int>(std::lround(offset * tx / main_axis))};
    box.include(c);
    marks.push_back(c);
  }
  grow_to_cover(box);
  for (const Cell& c : marks) {
    logodds_[index(c)] = l_max_;
    bumped_[index(c)] = 1;
  }
}

bool OccupancyGrid::add_visit(double x, double y, double speed_mps, double min_speed_mps) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!(speed_mps >= min_speed_mps)) return false;
  const Cell c = global_cell(x, y);
  if (has_last_visit_ && c == last_visit_) return false;  // standing or turning on the spot
  grow_to_cover(Box{c.row, c.row, c.col, c.col});
  ++visits_[index(c)];
  last_visit_ = c;
  has_last_visit_ = true;
  return true;
}

int OccupancyGrid::free_unknown_disc(double x, double y, double radius_m) {
  check(std::isfinite(x) && std::isfinite(y), "free_unknown_disc: position must be finite");
  check(std::isfinite(radius_m) && radius_m >= 0 && radius_m <= 10.0,
        "free_unknown_disc: radius_m must be in [0, 10]");
  std::lock_guard<std::mutex> lock(mutex_);
  const double res = settings_.resolution;
  const int k = static_cast<int>(std::ceil(radius_m / res));
  const Cell centre = global_cell(x, y);
  grow_to_cover(Box{centre.row - k, centre.row + k, centre.col - k, centre.col + k});
  int changed = 0;
  for (int r = centre.row - k; r <= centre.row + k; ++r) {
    for (int c = centre.col - k; c <= centre.col + k; ++c) {
      const double cx = settings_.origin_x + (c + 0.5) * res - x;   // global cells
      const double cy = settings_.origin_y + (r + 0.5) * res - y;
      if (cx * cx + cy * cy > radius_m * radius_m) continue;
      float& l = logodds_[index(Cell{r, c})];
      if (!std::isnan(l)) continue;
      l = l_min_;   // the robot stands there: as free as the map says anything
      ++changed;
    }
  }
  return changed;
}

void OccupancyGrid::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::fill(logodds_.begin(), logodds_.end(), std::numeric_limits<float>::quiet_NaN());
  std::fill(visits_.begin(), visits_.end(), 0);
  std::fill(bumped_.begin(), bumped_.end(), 0);
  has_last_visit_ = false;
}

void OccupancyGrid::set_logodds(const float* logodds, int rows, int cols) {
  std::lock_guard<std::mutex> lock(mutex_);
  check(rows == rows_ && cols == cols_, "set_logodds: a " + std::to_string(rows) + " x " + std::to_string(cols) +
                                            " array for a " + std::to_string(rows_) + " x " +
                                            std::to_string(cols_) + " grid");
  std::transform(logodds, logodds + logodds_.size(), logodds_.begin(), [this](float l) {
    return std::isnan(l) ? l : std::clamp(l, l_min_, l_max_);
  });
}

// ---------------------------------------------------------------------------------------
// Geometry and growth.

OccupancyGrid::Cell OccupancyGrid::global_cell(double x, double y) const {
  const double col = std::floor(grid_x(x));
  const double row = std::floor(grid_y(y));
  if (!(std::abs(col) < kMaxCellIndex && std::abs(row) < kMaxCellIndex))  // message built only on failure
    throw std::invalid_argument("OccupancyGrid: point (" + std::to_string(x) + ", " +
                                std::to_string(y) + ") is not a finite position near the map");
  return Cell{static_cast<int>(row), static_cast<int>(col)};
}

// Grows the window, once, to hold `box` plus the margin on each side the box leaves.
// Cell edges stay where they were: the origin moves by whole cells and old cells are copied
// to the same global index.
void OccupancyGrid::grow_to_cover(const Box& box) {
  const std::int64_t row_end = std::int64_t{row_offset_} + rows_;
  const std::int64_t col_end = std::int64_t{col_offset_} + cols_;
  if (box.row_min >= row_offset_ && box.row_max < row_end && box.col_min >= col_offset_ &&
      box.col_max < col_end)
    return;

  // Only the sides the box leaves move, each to the box plus the margin.
  std::int64_t new_row_offset = row_offset_, new_row_end = row_end;
  std::int64_t new_col_offset = col_offset_, new_col_end = col_end;
  if (box.row_min < row_offset_) new_row_offset = std::int64_t{box.row_min} - margin_cells_;
  if (box.row_max >= row_end) new_row_end = std::int64_t{box.row_max} + 1 + margin_cells_;
  if (box.col_min < col_offset_) new_col_offset = std::int64_t{box.col_min} - margin_cells_;
  if (box.col_max >= col_end) new_col_end = std::int64_t{box.col_max} + 1 + margin_cells_;
  const std::int64_t new_rows = new_row_end - new_row_offset, new_cols = new_col_end - new_col_offset;
  if (new_rows * new_cols > kMaxCells)
    throw std::length_error("OccupancyGrid: growing to " + std::to_string(new_rows) + " x " +
                            std::to_string(new_cols) + " cells is too large; check range_max and units");

  std::vector<float> logodds(static_cast<std::size_t>(new_rows * new_cols),
                             std::numeric_limits<float>::quiet_NaN());
  std::vector<std::int32_t> visits(logodds.size(), 0);
  std::vector<std::uint8_t> bumped(logodds.size(), 0);
  const std::int64_t shift_r = row_offset_ - new_row_offset, shift_c = col_offset_ - new_col_offset;
  for (int r = 0; r < rows_; ++r) {
    const std::size_t src = static_cast<std::size_t>(r) * cols_;
    const std::size_t dst = static_cast<std::size_t>((r + shift_r) * new_cols + shift_c);
    std::copy_n(logodds_.begin() + src, cols_, logodds.begin() + dst);
    std::copy_n(visits_.begin() + src, cols_, visits.begin() + dst);
    std::copy_n(bumped_.begin() + src, cols_, bumped.begin() + dst);
  }
  // Stamps only matter within a scan, and no scan is in progress here (insert_scan grows
  // before it stamps): the new window starts with none. Allocated before anything is swapped
  // so that a failed allocation leaves the grid as it was.
  std::vector<std::uint32_t> scan_stamps(logodds.size(), 0);
  logodds_.swap(logodds);
  visits_.swap(visits);
  bumped_.swap(bumped);
  scan_stamps_.swap(scan_stamps);
  row_offset_ = static_cast<int>(new_row_offset);
  col_offset_ = static_cast<int>(new_col_offset);
  rows_ = static_cast<int>(new_rows);
  cols_ = static_cast<int>(new_cols);
  ++grow_count_;
}

std::pair<int, int> OccupancyGrid::cell_of(double x, double y) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const Cell c = global_cell(x, y);
  return {c.row - row_offset_, c.col - col_offset_};
}

double OccupancyGrid::origin_x() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_.origin_x + col_offset_ * settings_.resolution;
}

double OccupancyGrid::origin_y() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_.origin_y + row_offset_ * settings_.resolution;
}

int OccupancyGrid::rows() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return rows_;
}

int OccupancyGrid::cols() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cols_;
}

int OccupancyGrid::grow_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return grow_count_;
}

}  // namespace turtlebot_recon

// =======================================================================================
// Python bindings: turtlebot_recon._native.OccupancyGrid / ScanStats.

#include "numpy_args.hpp"

namespace py = pybind11;
using turtlebot_recon::GridView;
using turtlebot_recon::OccupancyGrid;
using turtlebot_recon::ScanStats;

namespace {

using FloatArray = py::array_t<float, turtlebot_recon::bindings::kInFlags>;
using DoubleArray = py::array_t<double, turtlebot_recon::bindings::kInFlags>;

std::string repr(const ScanStats& s) {
  std::ostringstream o;
  o << "ScanStats(valid=" << s.valid << ", no_return=" << s.no_return << ", capped=" << s.capped
    << ", too_close=" << s.too_close << ", nan=" << s.nan << ", total=" << s.total << ")";
  return o.str();
}

std::string repr(const OccupancyGrid& g) {
  std::ostringstream o;
  o << "OccupancyGrid(rows=" << g.rows() << ", cols=" << g.cols()
    << ", resolution=" << g.resolution() << ", origin=(" << g.origin_x() << ", " << g.origin_y()
    << "), grow_count=" << g.grow_count() << ")";
  return o.str();
}

// One scan's description for OccupancyGrid::insert_scan (ranges not copied).
turtlebot_recon::Scan scan_at(double x, double y, double yaw, const float* ranges, std::size_t count,
                              double angle_min, double angle_increment, double range_min,
                              double range_max, double no_return_clear_m, double range_cap_m) {
  turtlebot_recon::Scan scan;
  scan.sensor_x = x;
  scan.sensor_y = y;
  scan.sensor_yaw = yaw;
  scan.ranges = ranges;
  scan.count = count;
  scan.angle_min = angle_min;
  scan.angle_increment = angle_increment;
  scan.range_min = range_min;
  scan.range_max = range_max;
  scan.no_return_clear_m = no_return_clear_m;
  scan.range_cap_m = range_cap_m;
  return scan;
}

ScanStats py_insert_scan(OccupancyGrid& grid, double sensor_x, double sensor_y, double sensor_yaw,
                         const FloatArray& ranges, double angle_min, double angle_increment,
                         double range_min, double range_max, double no_return_clear_m,
                         double range_cap_m) {
  if (ranges.ndim() != 1)
    throw std::invalid_argument("insert_scan: ranges must be a 1-D array, got " +
                                std::to_string(ranges.ndim()) + " dimensions");
  const auto scan = scan_at(sensor_x, sensor_y, sensor_yaw, ranges.data(),
                            static_cast<std::size_t>(ranges.shape(0)), angle_min, angle_increment,
                            range_min, range_max, no_return_clear_m, range_cap_m);
  py::gil_scoped_release release;
  return grid.insert_scan(scan);
}

// Re-rendering after a SLAM correction: the keyframes' scans (one lidar, so one beam layout)
// inserted at their optimised sensor poses, one after another, in one call without the GIL.
ScanStats py_insert_scans(OccupancyGrid& grid, const DoubleArray& poses, const FloatArray& ranges,
                          double angle_min, double angle_increment, double range_min,
                          double range_max, double no_return_clear_m, double range_cap_m) {
  if (poses.ndim() != 2 || poses.shape(1) != 3)
    throw std::invalid_argument("insert_scans: poses must be an (n, 3) array of x, y, yaw");
  if (ranges.ndim() != 2 || ranges.shape(0) != poses.shape(0))
    throw std::invalid_argument("insert_scans: ranges must be an (n, beams) array, one row per pose; got " +
                                std::to_string(ranges.ndim()) + "-D for " +
                                std::to_string(poses.shape(0)) + " poses");
  const auto n = static_cast<std::size_t>(poses.shape(0));
  const auto beams = static_cast<std::size_t>(ranges.shape(1));
  const double* p = poses.data();
  const float* r = ranges.data();
  ScanStats total;
  py::gil_scoped_release release;
  for (std::size_t i = 0; i < n; ++i) {
    const ScanStats s = grid.insert_scan(scan_at(p[3 * i], p[3 * i + 1], p[3 * i + 2], r + i * beams, beams,
                                                 angle_min, angle_increment, range_min, range_max,
                                                 no_return_clear_m, range_cap_m));
    total.valid += s.valid;
    total.no_return += s.no_return;
    total.capped += s.capped;
    total.too_close += s.too_close;
    total.nan += s.nan;
    total.total += s.total;
  }
  return total;
}

// A (rows, cols) array of T written from the grid's cells, under its lock, by
// fill(view, out, cell count).
template <class T, class Fill>
py::array_t<T> export_cells(const OccupancyGrid& grid, Fill fill) {
  py::array_t<T> out;
  grid.read([&](const GridView& v) {
    out = py::array_t<T>({py::ssize_t{v.rows}, py::ssize_t{v.cols}});
    fill(v, out.mutable_data(), static_cast<std::size_t>(v.rows) * v.cols);
  });
  return out;
}

}  // namespace

void register_mapping(py::module_& m) {
  py::class_<ScanStats>(m, "ScanStats", "How the beams of one scan were classified (counts).")
      .def_readonly("valid", &ScanStats::valid, "beams with a return in range: misses + a hit")
      .def_readonly("no_return", &ScanStats::no_return,
                    "+inf, 0.0 or beyond range_max: cleared up to no_return_clear_m")
      .def_readonly("capped", &ScanStats::capped, "returns beyond range_cap_m: cleared up to it")
      .def_readonly("too_close", &ScanStats::too_close, "-inf or below range_min: ignored")
      .def_readonly("nan", &ScanStats::nan, "NaN: ignored")
      .def_readonly("total", &ScanStats::total, "beams in the scan")
      .def("__repr__", [](const ScanStats& s) { return repr(s); });

  py::class_<OccupancyGrid>(
      m, "OccupancyGrid",
      "Log-odds occupancy grid (nav_msgs/OccupancyGrid cell order: row-major, row 0 = smallest y)\n"
      "filled by Bresenham ray casting; grows to fit what it is given. Lengths in m, angles in rad.")
      .def(py::init([](double resolution, double width_m, double height_m, double origin_x,
                       double origin_y, double p_hit, double p_miss, double p_min, double p_max,
                       double grow_margin_m) {
             turtlebot_recon::GridSettings s;
             s.resolution = resolution;
             s.width_m = width_m;
             s.height_m = height_m;
             s.origin_x = origin_x;
             s.origin_y = origin_y;
             s.p_hit = p_hit;
             s.p_miss = p_miss;
             s.p_min = p_min;
             s.p_max = p_max;
             s.grow_margin_m = grow_margin_m;
             return std::make_unique<OccupancyGrid>(s);
           }),
           py::arg("resolution"), py::arg("width_m"), py::arg("height_m"),
           py::arg("origin_x"), py::arg("origin_y"), py::arg("p_hit"),
           py::arg("p_miss"), py::arg("p_min"), py::arg("p_max"),
           py::arg("grow_margin_m"))
      .def("insert_scan", &py_insert_scan, py::arg("sensor_x"), py::arg("sensor_y"),
           py::arg("sensor_yaw"), py::arg("ranges"), py::arg("angle_min"),
           py::arg("angle_increment"), py::arg("range_min"), py::arg("range_max"),
           py::arg("no_return_clear_m"), py::arg("range_cap_m"),
           "Insert one scan taken at the sensor pose (map frame). ranges: 1-D float32 array (m),\n"
           "beam i at sensor_yaw + angle_min + i*angle_increment. Returns ScanStats.")
      .def("insert_scans", &py_insert_scans, py::arg("poses"), py::arg("ranges"),
           py::arg("angle_min"), py::arg("angle_increment"), py::arg("range_min"),
           py::arg("range_max"), py::arg("no_return_clear_m"), py::arg("range_cap_m"),
           "Insert n scans of one lidar in order: poses (n, 3) sensor x, y, yaw (map frame),\n"
           "ranges (n, beams) float32. Returns the ScanStats summed over the scans.")
      .def("mark_bumper", &OccupancyGrid::mark_bumper, py::arg("x"), py::arg("y"), py::arg("yaw"),
           py::arg("bumper_angle_rad"), py::arg("robot_radius_m"), py::arg("cells"),
           "Mark `cells` cells occupied along the body's tangent where the bumper at body angle\n"
           "bumper_angle_rad (0 centre, + left) touched something; the robot is at (x, y, yaw).")
      .def("add_visit", &OccupancyGrid::add_visit, py::arg("x"), py::arg("y"), py::arg("speed_mps"),
           py::arg("min_speed_mps"),
           "Count a visit of the cell holding (x, y) if moving at >= min_speed_mps and not in the\n"
           "cell counted last. Returns whether it counted.")
      .def("free_unknown_disc", &OccupancyGrid::free_unknown_disc, py::arg("x"), py::arg("y"),
           py::arg("radius_m"),
           "The robot stands on the disc of radius_m around (x, y): its still-unknown cells become\n"
           "free (p_min; known cells keep their value). Returns the number of cells changed.")
      .def("occupancy",
           [](const OccupancyGrid& g) {
             return export_cells<std::int8_t>(g, [](const GridView& v, std::int8_t* o, std::size_t n) {
               std::transform(v.logodds, v.logodds + n, o, turtlebot_recon::occupancy_value);
             });
           },
           "int8 (rows, cols) in ROS values: -1 unknown, else round(100 p).")
      .def("visits", [](const OccupancyGrid& g) {
             return export_cells<std::int32_t>(g, [](const GridView& v, std::int32_t* o, std::size_t n) {
               std::copy_n(v.visits, n, o);
             });
           }, "int32 (rows, cols) visit counts (a copy).")
      .def("logodds", [](const OccupancyGrid& g) {
             return export_cells<float>(g, [](const GridView& v, float* o, std::size_t n) {
               std::copy_n(v.logodds, n, o);
             });
           }, "float32 (rows, cols) log-odds, NaN = unknown (a copy).")
      .def("cell", [](const OccupancyGrid& g, double x, double y) {
             const auto [row, col] = g.cell_of(x, y);
             return py::make_tuple(row, col);
           }, py::arg("x"), py::arg("y"),
           "(row, col) of the cell holding (x, y); may lie outside the grid.")
      .def("clear", &OccupancyGrid::clear, "Every cell unknown, every visit count 0.")
      .def("set_logodds",
           [](OccupancyGrid& g, py::array_t<float, py::array::c_style | py::array::forcecast> l) {
             if (l.ndim() != 2) throw std::invalid_argument("set_logodds: need a 2-D array");
             g.set_logodds(l.data(), static_cast<int>(l.shape(0)), static_cast<int>(l.shape(1)));
           },
           py::arg("logodds"),
           "A prior map: float32 (rows, cols) log-odds in the grid's shape, NaN = unknown; clamped\n"
           "to the grid's p_min / p_max so that scans can still change it.")
      .def_property_readonly("resolution", &OccupancyGrid::resolution, "m per cell")
      .def_property_readonly("origin_x", &OccupancyGrid::origin_x, "m, x of the lower-left corner")
      .def_property_readonly("origin_y", &OccupancyGrid::origin_y, "m, y of the lower-left corner")
      .def_property_readonly("rows", &OccupancyGrid::rows)
      .def_property_readonly("cols", &OccupancyGrid::cols)
      .def_property_readonly("grow_count", &OccupancyGrid::grow_count, "times the grid grew")
      .def("__repr__", [](const OccupancyGrid& g) { return repr(g); });
}
