// The OctoMap layer (octomap_layer.hpp) and its bindings: ray casting, pruning and the .bt file
// are OctoMap's; this file checks the input, skips non-finite points and projects the occupied
// voxels of a height band onto a 2-D grid.
#include "turtlebot_recon/octomap_layer.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "numpy_args.hpp"

namespace turtlebot_recon {

namespace {

void check(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

bool finite3(float x, float y, float z) {
  return std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
}

// Whether a leaf whose lower face is at z0 and edge `size` holds a finest voxel (edge `res`)
// centred in (band.floor_band_m, band.robot_height_m]: a pruned leaf stands for all of them.
bool in_band(double z0, double size, double res, const HeightBand& band) {
  const double first = z0 + 0.5 * res;  // the lowest finest centre
  const int n = std::max(1, static_cast<int>(std::lround(size / res)));
  // the first finest centre above the floor band
  const int k = std::max(0, static_cast<int>(std::floor((band.floor_band_m - first) / res)) + 1);
  return k < n && first + k * res <= band.robot_height_m;
}

// The cells [lo, hi] along one axis that the interval [a, b) overlaps (not just touches),
// clipped to [0, n); hi < lo when none.
void cell_span(double a, double b, double origin, double res, int n, int& lo, int& hi) {
  constexpr double kTouch = 1e-6;  // in cells: an edge shared with the next cell is not overlap
  lo = std::max(0, static_cast<int>(std::floor((a - origin) / res + kTouch)));
  hi = std::min(n - 1, static_cast<int>(std::ceil((b - origin) / res - kTouch)) - 1);
}

}  // namespace

void validate(const OctomapParams& p) {
  check(std::isfinite(p.resolution) && p.resolution > 0,
        "OctomapLayer: resolution must be > 0 m, got " + std::to_string(p.resolution));
  check(p.prob_hit > 0.5 && p.prob_hit < 1.0,
        "OctomapLayer: prob_hit must be in (0.5, 1), got " + std::to_string(p.prob_hit));
  check(p.prob_miss > 0.0 && p.prob_miss < 0.5,
        "OctomapLayer: prob_miss must be in (0, 0.5), got " + std::to_string(p.prob_miss));
  check(p.clamping_thres_min > 0.0 && p.clamping_thres_min < p.occupancy_thres &&
            p.occupancy_thres < p.clamping_thres_max && p.clamping_thres_max < 1.0,
        "OctomapLayer: need 0 < clamping_thres_min < occupancy_thres < clamping_thres_max < 1, got " +
            std::to_string(p.clamping_thres_min) + ", " + std::to_string(p.occupancy_thres) + ", " +
            std::to_string(p.clamping_thres_max));
}

namespace {

// The parameters, once validate() has passed them (the tree is built only from valid ones).
const OctomapParams& checked(const OctomapParams& p) {
  validate(p);
  return p;
}

}  // namespace

OctomapLayer::OctomapLayer(const OctomapParams& params)
    : params_(checked(params)), tree_(params.resolution) {
  apply_sensor_model();
}

void OctomapLayer::apply_sensor_model() {
  tree_.setProbHit(params_.prob_hit);
  tree_.setProbMiss(params_.prob_miss);
  tree_.setClampingThresMin(params_.clamping_thres_min);
  tree_.setClampingThresMax(params_.clamping_thres_max);
  tree_.setOccupancyThres(params_.occupancy_thres);
}

CloudStats OctomapLayer::insert_point_cloud(const float* xyz, std::size_t count, double origin_x,
                                            double origin_y, double origin_z, double max_range_m,
                                            double max_z_m, bool discretize) {
  check(std::isfinite(origin_x) && std::isfinite(origin_y) && std::isfinite(origin_z),
        "insert_point_cloud: the sensor origin must be finite");
  check(std::isfinite(max_range_m), "insert_point_cloud: max_range_m must be finite (<= 0: no limit)");
  check(!std::isnan(max_z_m), "insert_point_cloud: max_z_m must be a number (inf: no limit)");
  std::lock_guard<std::mutex> lock(mutex_);
  CloudStats stats;
  cloud_.clear();
  cloud_.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const float* p = xyz + 3 * i;
    if (!finite3(p[0], p[1], p[2])) {
      ++stats.non_finite;
      continue;
    }
    if (p[2] > max_z_m) {
      ++stats.above_max_z;
      continue;
    }
    cloud_.push_back(p[0], p[1], p[2]);
  }
  stats.inserted = static_cast<int>(cloud_.size());
  if (cloud_.size() == 0) return stats;
  const octomap::point3d origin(static_cast<float>(origin_x), static_cast<float>(origin_y),
                                static_cast<float>(origin_z));
  // Not lazy: each voxel update also updates its parents and prunes, so the tree stays
  // consistent between clouds (a lazy update would need updateInnerOccupancy over the whole
  // tree after every cloud).
  tree_.insertPointCloud(cloud_, origin, max_range_m > 0 ? max_range_m : -1.0,
                         /*lazy_eval=*/false, discretize);
  return stats;
}

void OctomapLayer::project(const GridGeometry& g, const HeightBand& band, std::int8_t* out) const {
  check(g.rows > 0 && g.cols > 0, "project: the grid needs rows > 0 and cols > 0");
  check(std::isfinite(g.resolution) && g.resolution > 0, "project: the grid resolution must be > 0 m");
  check(std::isfinite(g.origin_x) && std::isfinite(g.origin_y), "project: the grid origin must be finite");
  check(std::isfinite(band.floor_band_m) && std::isfinite(band.robot_height_m) &&
            band.floor_band_m < band.robot_height_m,
        "project: need floor_band_m < robot_height_m, got " + std::to_string(band.floor_band_m) +
            " and " + std::to_string(band.robot_height_m));
  std::fill(out, out + static_cast<std::size_t>(g.rows) * g.cols, std::int8_t{-1});
  std::lock_guard<std::mutex> lock(mutex_);
  if (tree_.size() == 0) return;
  const double res = tree_.getResolution();
  // Only the leaves that can reach the band and the grid: OctoMap's bounding-box iterator.
  const octomap::point3d lo(static_cast<float>(g.origin_x), static_cast<float>(g.origin_y),
                            static_cast<float>(band.floor_band_m));
  const octomap::point3d hi(static_cast<float>(g.origin_x + g.cols * g.resolution),
                            static_cast<float>(g.origin_y + g.rows * g.resolution),
                            static_cast<float>(band.robot_height_m));
  for (auto it = tree_.begin_leafs_bbx(lo, hi), end = tree_.end_leafs_bbx(); it != end; ++it) {
    if (!tree_.isNodeOccupied(*it)) continue;
    const double size = it.getSize();
    const double half = 0.5 * size;
    if (!in_band(it.getZ() - half, size, res, band)) continue;
    int c0, c1, r0, r1;
    cell_span(it.getX() - half, it.getX() + half, g.origin_x, g.resolution, g.cols, c0, c1);
    cell_span(it.getY() - half, it.getY() + half, g.origin_y, g.resolution, g.rows, r0, r1);
    for (int r = r0; r <= r1; ++r)
      std::fill(out + static_cast<std::size_t>(r) * g.cols + c0,
                out + static_cast<std::size_t>(r) * g.cols + c1 + 1, std::int8_t{100});
  }
}

int OctomapLayer::free_body(double x, double y, double radius_m, double z_top_m) {
  check(std::isfinite(x) && std::isfinite(y), "free_body: the position must be finite");
  check(std::isfinite(radius_m) && radius_m >= 0 && std::isfinite(z_top_m) && z_top_m >= 0,
        "free_body: need radius_m >= 0 and z_top_m >= 0, finite");
  std::lock_guard<std::mutex> lock(mutex_);
  const double res = tree_.getResolution();
  const int n = static_cast<int>(std::ceil(radius_m / res));
  const int levels = static_cast<int>(std::floor(z_top_m / res));
  int updated = 0;
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      // the centre of the voxel column (i, j) voxels away from the one holding (x, y)
      const double cx = (std::floor(x / res) + i + 0.5) * res;
      const double cy = (std::floor(y / res) + j + 0.5) * res;
      if (std::hypot(cx - x, cy - y) > radius_m) continue;
      for (int k = 0; k < levels; ++k) {
        tree_.updateNode(octomap::point3d(static_cast<float>(cx), static_cast<float>(cy),
                                          static_cast<float>((k + 0.5) * res)),
                         false);
        ++updated;
      }
    }
  }
  return updated;
}

VoxelList OctomapLayer::occupied_voxels() const {
  std::lock_guard<std::mutex> lock(mutex_);
  VoxelList v;
  for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
    if (!tree_.isNodeOccupied(*it)) continue;
    v.centres.insert(v.centres.end(), {it.getX(), it.getY(), it.getZ()});
    v.sizes.push_back(it.getSize());
  }
  return v;
}

void OctomapLayer::probabilities(const double* xyz, std::size_t count, double* out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (std::size_t i = 0; i < count; ++i) {
    const double* p = xyz + 3 * i;
    const octomap::OcTreeNode* node =
        std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])
            ? tree_.search(p[0], p[1], p[2])
            : nullptr;
    out[i] = node ? node->getOccupancy() : std::numeric_limits<double>::quiet_NaN();
  }
}

void OctomapLayer::write_bt(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!tree_.writeBinaryConst(path))
    throw std::runtime_error("write_bt: cannot write " + path);
}

void OctomapLayer::read_bt(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  octomap::OcTree loaded(params_.resolution);
  if (!loaded.readBinary(path))
    throw std::runtime_error("read_bt: cannot read an OctoMap .bt file from " + path);
  tree_.swapContent(loaded);                     // the nodes and their count only
  tree_.setResolution(loaded.getResolution());
  params_.resolution = tree_.getResolution();
}

std::size_t OctomapLayer::memory_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tree_.memoryUsage();
}

std::size_t OctomapLayer::leaf_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tree_.getNumLeafNodes();
}

double OctomapLayer::resolution() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tree_.getResolution();
}

}  // namespace turtlebot_recon

// ------------------------------------------------------------------------------------ bindings

namespace py = pybind11;
using turtlebot_recon::CloudStats;
using turtlebot_recon::OctomapLayer;
using namespace turtlebot_recon::bindings;  // numpy argument types and shape checks

namespace {

using FloatArray = py::array_t<float, kInFlags>;
using DoubleArray = py::array_t<double, kInFlags>;

// The number n of an (n, 3) points argument; an empty one may also come as shape (0,).
std::size_t point_count(const py::array& a, const char* fn, const char* name) {
  if (!(a.size() == 0 || (a.ndim() == 2 && a.shape(1) == 3)))
    fail(fn, std::string(name) + " must be an (n, 3) array of x, y, z (m)");
  return static_cast<std::size_t>(a.size() / 3);
}

std::string repr(const CloudStats& s) {
  std::ostringstream o;
  o << "CloudStats(inserted=" << s.inserted << ", non_finite=" << s.non_finite
    << ", above_max_z=" << s.above_max_z << ")";
  return o.str();
}

std::string repr(const OctomapLayer& l) {
  const auto& p = l.params();
  std::ostringstream o;
  o << "OctomapLayer(resolution=" << l.resolution() << ", leaves=" << l.leaf_count()
    << ", memory_bytes=" << l.memory_bytes() << ", prob_hit=" << p.prob_hit
    << ", prob_miss=" << p.prob_miss << ")";
  return o.str();
}

CloudStats py_insert(OctomapLayer& layer, const FloatArray& points, double origin_x,
                     double origin_y, double origin_z, double max_range_m, double max_z_m,
                     bool discretize) {
  const std::size_t n = point_count(points, "insert_point_cloud", "points");
  py::gil_scoped_release release;
  return layer.insert_point_cloud(points.data(), n, origin_x, origin_y, origin_z, max_range_m,
                                  max_z_m, discretize);
}

py::array_t<std::int8_t> py_project(const OctomapLayer& layer, int rows, int cols,
                                    double resolution, double origin_x, double origin_y,
                                    double floor_band_m, double robot_height_m) {
  if (rows <= 0 || cols <= 0) fail("project", "the grid needs rows > 0 and cols > 0");
  py::array_t<std::int8_t> out({py::ssize_t{rows}, py::ssize_t{cols}});
  std::int8_t* dst = out.mutable_data();
  const turtlebot_recon::GridGeometry g{rows, cols, resolution, origin_x, origin_y};
  const turtlebot_recon::HeightBand band{floor_band_m, robot_height_m};
  py::gil_scoped_release release;
  layer.project(g, band, dst);
  return out;
}

py::tuple py_occupied_voxels(const OctomapLayer& layer) {
  turtlebot_recon::VoxelList v;
  {
    py::gil_scoped_release release;
    v = layer.occupied_voxels();
  }
  const auto n = static_cast<py::ssize_t>(v.sizes.size());
  py::array_t<double> centres({n, py::ssize_t{3}});
  py::array_t<double> sizes(n);
  std::copy(v.centres.begin(), v.centres.end(), centres.mutable_data());
  std::copy(v.sizes.begin(), v.sizes.end(), sizes.mutable_data());
  return py::make_tuple(centres, sizes);
}

py::array_t<double> py_probabilities(const OctomapLayer& layer, const DoubleArray& points) {
  const std::size_t n = point_count(points, "probabilities", "points");
  py::array_t<double> out(static_cast<py::ssize_t>(n));
  layer.probabilities(points.data(), n, out.mutable_data());
  return out;
}

}  // namespace

void register_octomap(py::module_& m) {
  py::class_<CloudStats>(m, "CloudStats", "What one insert_point_cloud did with its points (counts).")
      .def_readonly("inserted", &CloudStats::inserted,
                    "finite points ray-cast into the tree (beyond max range: cleared up to it)")
      .def_readonly("non_finite", &CloudStats::non_finite, "points with a NaN or inf coordinate: skipped")
      .def_readonly("above_max_z", &CloudStats::above_max_z, "points higher than max_z_m: skipped")
      .def("__repr__", [](const CloudStats& s) { return repr(s); });

  py::class_<OctomapLayer>(
      m, "OctomapLayer",
      "An octomap::OcTree filled by ray casting point clouds (map frame, m, z up) and projected\n"
      "onto a 2-D grid as the obstacles of a height band.")
      .def(py::init([](double resolution, double prob_hit, double prob_miss,
                       double clamping_thres_min, double clamping_thres_max,
                       double occupancy_thres) {
             turtlebot_recon::OctomapParams p;
             p.resolution = resolution;
             p.prob_hit = prob_hit;
             p.prob_miss = prob_miss;
             p.clamping_thres_min = clamping_thres_min;
             p.clamping_thres_max = clamping_thres_max;
             p.occupancy_thres = occupancy_thres;
             return std::make_unique<OctomapLayer>(p);
           }),
           py::arg("resolution"), py::arg("prob_hit"), py::arg("prob_miss"),
           py::arg("clamping_thres_min"), py::arg("clamping_thres_max"), py::arg("occupancy_thres"))
      .def("insert_point_cloud", &py_insert, py::arg("points"), py::arg("origin_x"),
           py::arg("origin_y"), py::arg("origin_z"), py::arg("max_range_m"), py::arg("max_z_m"),
           py::arg("discretize"),
           "Ray-cast points (n, 3) float32 (m, map frame) from the sensor origin with OctoMap's\n"
           "insertPointCloud: crossed voxels free, end voxels occupied; a point beyond max_range_m\n"
           "clears its ray up to it (<= 0: no limit). Non-finite points and points above max_z_m\n"
           "(m; inf: no limit) are skipped. Returns CloudStats.")
      .def("project", &py_project, py::arg("rows"), py::arg("cols"), py::arg("resolution"),
           py::arg("origin_x"), py::arg("origin_y"), py::arg("floor_band_m"),
           py::arg("robot_height_m"),
           "int8 (rows, cols) in nav_msgs/OccupancyGrid order (row 0 = smallest y; origin: the\n"
           "lower-left corner of cell (0, 0), m): 100 under an occupied voxel centred in\n"
           "(floor_band_m, robot_height_m], else -1 (the layer knows no free space).")
      .def("free_body", &OctomapLayer::free_body, py::arg("x"), py::arg("y"), py::arg("radius_m"),
           py::arg("z_top_m"), py::call_guard<py::gil_scoped_release>(),
           "The robot's body on the disc of radius_m (m) around (x, y) (m, map frame), from the\n"
           "floor to z_top_m: one miss for each voxel centred in that cylinder. Returns how many.")
      .def("occupied_voxels", &py_occupied_voxels,
           "(centres (n, 3) float64 m, sizes (n,) float64 m): every occupied leaf.")
      .def("probabilities", &py_probabilities, py::arg("points"),
           "Occupancy probability (n,) at points (n, 3) (m, map frame); NaN where never observed.")
      .def("write_bt", &OctomapLayer::write_bt, py::arg("path"),
           "Write the tree as an OctoMap .bt file (octovis reads it); the tree is not changed.")
      .def("read_bt", &OctomapLayer::read_bt, py::arg("path"),
           "Replace the tree by a .bt file's (resolution included).")
      .def_property_readonly("memory_bytes", &OctomapLayer::memory_bytes, "OcTree::memoryUsage, bytes")
      .def_property_readonly("leaf_count", &OctomapLayer::leaf_count, "leaves (pruned ones count once)")
      .def_property_readonly("resolution", &OctomapLayer::resolution, "m, finest voxel edge")
      .def("__repr__", [](const OctomapLayer& l) { return repr(l); });
}
