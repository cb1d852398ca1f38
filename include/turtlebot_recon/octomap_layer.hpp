// The 3-D obstacle layer: an octomap::OcTree filled from point clouds (a depth camera, a lidar
// at its mounting height) by OctoMap's own ray casting, and projected onto the 2-D grid as the
// obstacles the lidar's one plane misses (a box below it, a shelf between it and the robot's
// top).
//
// Everything probabilistic is OctoMap's: insertPointCloud (each voxel updated at most once per
// cloud, occupied wins; points beyond the maximum range clear up to it and mark nothing),
// its sensor model (hit / miss log-odds, clamping), pruning and the .bt file format. This
// class adds the checks on its input, the non-finite points it skips, and the projection.
//
// Frames and units: points, sensor origin and voxel centres in metres in the map frame (z up,
// the floor at z = 0). The 2-D grid follows nav_msgs/OccupancyGrid (occupancy_grid.hpp): row-
// major, row 0 = smallest y, cell (r, c) covers x in [origin_x + c*res, origin_x + (c+1)*res).
//
// Thread safety: every public method locks the layer's mutex, so a cloud thread and a
// publishing thread may share one layer (the Python binding releases the GIL in the long calls).
#pragma once

#include <octomap/OcTree.h>

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace turtlebot_recon {

// The tree's resolution and OctoMap's sensor model; the defaults are OctoMap's own (OcTree's
// constructor), which config/octomap.yaml repeats.
struct OctomapParams {
  double resolution = 0.05;            // m, edge of the finest voxel
  double prob_hit = 0.7;               // occupancy probability a point's end voxel votes for, in (0.5, 1)
  double prob_miss = 0.4;              // ... a voxel the ray crosses votes for, in (0, 0.5)
  double clamping_thres_min = 0.1192;  // a voxel never gets surer than this of free ...
  double clamping_thres_max = 0.971;   // ... nor of occupied (then it can be pruned)
  double occupancy_thres = 0.5;        // occupied above this probability, free at or below
};

// Throws std::invalid_argument naming the first bad value.
void validate(const OctomapParams& params);

// What insert_point_cloud did with a cloud.
struct CloudStats {
  int inserted = 0;     // points handed to OctoMap (beyond max range: cleared up to it)
  int non_finite = 0;   // points with a NaN or infinite coordinate: skipped
  int above_max_z = 0;  // points higher than max_z_m: skipped
};

// The 2-D grid the layer is projected onto (any resolution and origin; the lidar grid's).
struct GridGeometry {
  int rows = 0, cols = 0;
  double resolution = 0.0;  // m per cell
  double origin_x = 0.0;    // m, map-frame x of cell (0, 0)'s lower-left corner
  double origin_y = 0.0;    // m
};

// The height band whose occupied voxels are obstacles to the robot.
struct HeightBand {
  double floor_band_m = 0.0;    // m, voxels centred at or below this height are the floor
  double robot_height_m = 0.0;  // m, voxels centred above this pass over the robot's top
};

// Occupied leaves: centres (n x 3, x y z, m, row-major) and edge lengths (m; a pruned leaf is a
// cube of 2^k finest voxels).
struct VoxelList {
  std::vector<double> centres;
  std::vector<double> sizes;
};

class OctomapLayer {
 public:
  // Throws std::invalid_argument on bad parameters.
  explicit OctomapLayer(const OctomapParams& params);

  // Ray-casts `count` points (xyz, row-major float, map frame) from the sensor origin with
  // OctoMap's insertPointCloud: every voxel a ray crosses gets one miss, every end voxel one
  // hit; a point farther than max_range_m clears its ray up to max_range_m and marks nothing
  // (max_range_m <= 0: no limit). discretize: OctoMap's option, one ray per end voxel rather
  // than per point (faster on dense clouds; the same end voxels). Points with a non-finite
  // coordinate are skipped, and so are points higher than max_z_m (octomap_server's
  // pointcloud_max_z: the free space of rays rising above the robot is most of a depth
  // frame's cost and none of the layer's concern); both are counted. Throws
  // std::invalid_argument on a non-finite origin or max range, or a NaN max_z_m.
  CloudStats insert_point_cloud(const float* xyz, std::size_t count, double origin_x,
                                double origin_y, double origin_z, double max_range_m,
                                double max_z_m, bool discretize);

  // Writes rows*cols int8 into `out`: 100 where an occupied voxel whose centre height lies in
  // (floor_band_m, robot_height_m] covers the cell (its square footprint overlaps the cell's),
  // else -1: the layer knows only obstacles, never free space (a column of voxels seen free
  // at one height may hide an unseen obstacle at another), so merged with the lidar grid as a
  // cell-wise maximum it adds obstacles and changes nothing else. Throws std::invalid_argument
  // on a bad geometry or band.
  void project(const GridGeometry& grid, const HeightBand& band, std::int8_t* out) const;

  // The robot's body stands on the disc of radius_m around (x, y) (map frame, m) from the
  // floor to z_top_m: each voxel whose centre lies in that cylinder gets one miss (OctoMap's
  // updateNode(key, false)), as if a ray had crossed it. The camera never sees the space the
  // body fills (inside its minimum range), so without this the band under the robot's own
  // track stays unknown. Returns the number of voxels updated. Throws std::invalid_argument
  // on a non-finite or negative input.
  int free_body(double x, double y, double radius_m, double z_top_m);

  // Every occupied leaf (for markers), in OctoMap's leaf order.
  VoxelList occupied_voxels() const;

  // Occupancy probability at each of `count` points (xyz, map frame) into `out`; NaN where the
  // tree knows nothing (never observed).
  void probabilities(const double* xyz, std::size_t count, double* out) const;

  // The tree as a .bt file (OctoMap's binary format: occupied / free per leaf, read by octovis
  // and octomap_server). Written with writeBinaryConst, which leaves the tree as it is;
  // writeBinary would first turn the live tree into its maximum-likelihood copy, throwing away
  // the log-odds that later clouds update. Throws std::runtime_error if the file cannot be
  // written.
  void write_bt(const std::string& path) const;

  // Replaces the tree by a .bt file's (its resolution included; the sensor model stays this
  // layer's). Throws std::runtime_error if it cannot be read.
  void read_bt(const std::string& path);

  std::size_t memory_bytes() const;  // OcTree::memoryUsage
  std::size_t leaf_count() const;    // OcTree::getNumLeafNodes
  double resolution() const;
  const OctomapParams& params() const { return params_; }

 private:
  void apply_sensor_model();

  OctomapParams params_;
  octomap::OcTree tree_;
  octomap::Pointcloud cloud_;  // the finite points of the cloud being inserted, reused
  mutable std::mutex mutex_;
};

}  // namespace turtlebot_recon
