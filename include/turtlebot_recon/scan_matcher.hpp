// Scan-to-submap matching for a 2-D lidar: the SLAM front end (issue 17).
//
// Given a scan (points in its own sensor frame), a local submap (reference points in the map
// frame) and a guess of the scan's pose, find the pose that lays the scan on the submap, with a
// covariance and a score. Two stages, each the algorithm of a paper:
//
//   1. Correlative coarse search: E. Olson, "Real-time correlative scan matching", ICRA 2009.
//      The reference points are rasterised into a lookup grid whose cells hold the likelihood
//      of a lidar return there: a Gaussian of the distance to the nearest reference cell (the
//      sensor noise, at least one cell wide). The pose is searched exhaustively over a window
//      of (dx, dy, dyaw) around the guess: rotations outermost, the scan rotated once per yaw
//      and turned into cell indices, so that each translation is an integer offset added to
//      them. Two resolutions (Olson's section IV-B): a low-resolution grid whose cells hold the
//      maximum of the fine cells of a D x D block of translations bounds the score of the whole
//      block; blocks are visited best bound first and opened (every fine offset scored) while
//      their bound still reaches the best score found: branch and bound, as exact as the
//      exhaustive search.
//   2. Point-to-line ICP: A. Censi, "An ICP variant using a point-to-line metric", ICRA 2008.
//      Each scan point is paired with a nearby reference line; its residual is the distance to
//      that line, and Gauss-Newton on (x, y, yaw) minimises the sum of Huber-weighted squared
//      residuals, pairs recomputed at each iteration. Censi's line runs through the two nearest
//      points of one ordered reference scan. A submap of several overlapping scans has no beam
//      order, and its two nearest points may come from two scans a millimetre apart, so here
//      the line is the least-squares fit (centroid and scatter's minor axis: the tangent of
//      point-to-plane ICP, Chen & Medioni 1991) to the reference points of the cells within
//      normal_radius_m of a reference cell, fitted once per cell of the lookup grid that holds
//      reference points. A fit that is not line-like (a corner, a lone point) pairs with
//      nothing. A surface has two faces: with the viewpoints the reference points were seen
//      from, the line's centroid is taken apart for each face (the points seen from that side
//      of the line), and a scan point pairs with the face its own ray meets. Without it, a
//      wall thinner than 2 normal_radius_m seen from both sides (a door frame, a partition
//      seen from the next room) gets one line down its middle, and every scan of one face is
//      pulled half the wall's thickness towards the other: a few millimetres per keyframe,
//      always back towards where the robot came from, the map shrinking by ~0.5 % in a house.
//
// Nearest neighbours: no KD-tree. Every cell of the lookup grid within max_correspondence_m of
// a reference cell stores the nearest one (by cell centres), so a scan point finds its line in
// one lookup. The choice is quantised to a cell (grid_resolution_m); the residual is not: it is
// measured to the fitted line.
//
// ICP starts within a cell and a yaw step of the best pose of the window (the search is
// exhaustive); a refinement that slides farther (max_correspondence_m, or a few yaw steps) is
// following wrong pairs, and the match is refused.
//
// Covariance, in GTSAM's Pose2 convention (a right, body-frame perturbation of the returned
// pose): sigma^2 (J^T W J)^-1 at the solution, J the residuals' Jacobian, W the Huber weights,
// sigma^2 the weighted residual variance, floored by sigma_m^2. A Hessian covariance ignores the
// correlation between neighbouring points, which makes it optimistic in general; with the
// floor (a good match's residuals are ~1 cm, sigma_m 3 cm) it came out 1.2-3x the scatter of
// repeated matches in simulation. It grows and shrinks with the scan's structure, which a
// constant cannot.
//
// Score: the fraction of all scan points within inlier_m of the reference at the solution (a
// loop closure's acceptance test); response: Olson's normalised correlative score of the
// coarse pose (the lookup values summed over the scan, / 255 n).
//
// Degeneracy (a corridor; J. Zhang, M. Kaess, S. Singh, "On degeneracy of optimization-based
// state estimation problems", ICRA 2016): the eigenvalues l_min <= l_max of the translational
// block of J^T W J. When l_min < degeneracy_ratio l_max the scan does not fix the pose along
// the eigenvector of l_min (the corridor's axis): the pose keeps the guess along it, Gauss-
// Newton steps are projected onto the other two dimensions (Zhang's solution remapping), and
// the covariance along it is set to degenerate_std_m^2, so that odometry rules that direction
// in the pose graph. It is checked at the coarse pose and again at the refined one.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace turtlebot_recon::slam {

struct Pose2 {
  double x = 0, y = 0, yaw = 0;  // m, m, rad
};

struct MatcherParams {
  double search_xy_m = 0.3;            // m, half-width of the coarse search window in x and y
  double search_yaw_rad = 0.3;         // rad, half-width of the window in yaw
  double grid_resolution_m = 0.05;     // m, cell of the lookup grid = the translation step
  double coarse_resolution_m = 0.2;    // m, side of a block of translations bounded at once
                                       // (rounded to whole cells)
  double coarse_yaw_step_rad = 0.015;  // rad, yaw step of the search (0.05 m of arc at 3.5 m)
  double sigma_m = 0.03;               // m, lidar range noise std: blurs the lookup grid (at
                                       // least one cell) and floors the covariance
  int icp_iterations = 15;             // at most this many Gauss-Newton iterations per pass
  double max_correspondence_m = 0.15;  // m, a scan point pairs with a reference cell this near
  double normal_radius_m = 0.1;        // m, reference cells within this fit a cell's line
  double huber_m = 0.03;               // m, Huber kernel: residuals beyond it weigh k / |r|
  double inlier_m = 0.05;              // m, residual up to which a scan point counts in the score
  int min_points = 30;                 // fewer scan points, reference points or pairs: no match
  double degeneracy_ratio = 0.03;      // l_min / l_max of the translational information below
                                       // this: degenerate
  double degenerate_std_m = 1.0;       // m, std put on the degenerate direction
  double max_range_m = 20.0;           // m, scan points farther than this from the sensor are not
                                       // matched: it bounds the reference's grid whatever the
                                       // laser reports (validate: the largest grid fits)
};

struct MatchResult {
  bool ok = false;
  std::string failure;              // why not ok (empty when ok)
  Pose2 pose;                       // the scan frame in the reference frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of (x, y, yaw), body frame (Pose2)
  double score = 0;                 // fraction of scan points with a residual <= inlier_m
  double response = 0;              // Olson's normalised correlative response at the coarse pose
  bool degenerate = false;
  Eigen::Vector2d degenerate_direction = Eigen::Vector2d::Zero();  // unit, reference frame
  double conditioning = 0;          // l_min / l_max of the translational information
  int points_used = 0;              // point-to-line pairs at the solution
  int iterations = 0;               // Gauss-Newton iterations, all passes
};

// Gauss-Newton stops when a step moves less than this.
constexpr double kConvergedM = 1e-5;
constexpr double kConvergedRad = 1e-5;
// A fit is a line when the spread across it is at most this fraction of the spread along it
// (eigenvalues of the scatter; an L-shaped corner gives 0.25 at its apex).
constexpr double kMaxLineSpread = 0.2;
// A line is fitted to at least this many points, spread along it with a standard deviation
// of at least this fraction of normal_radius_m (a wall seen over the whole window: 0.58).
constexpr int kMinLinePoints = 3;
constexpr double kMinLineExtent = 0.25;
// ICP may move the pose at most max_correspondence_m (across the degenerate direction, when
// there is one) and max(this many yaw steps of the search, kMinSlideRad) from the coarse pose.
constexpr double kMaxSlideSteps = 4.0;
constexpr double kMinSlideRad = 0.02;
// Largest grid (cells, ~15 bytes each): a safety bound; cropped around the scan, a 3.5 m lidar
// needs ~200 x 200. validate() refuses parameters whose largest grid (max_range_m) exceeds it.
constexpr long kMaxGridCells = 2000L * 2000L;

// The largest grid side (cells) a match can need: the reference cropped to a disc around the
// guess (crop_radius_m) plus the padding of build_grid.
inline double crop_radius_m(const MatcherParams& p, double reach_m) {
  return reach_m + std::sqrt(2.0) * p.search_xy_m + 2.0 * p.max_correspondence_m;
}

// Throws std::invalid_argument ("ScanMatcher: ...") naming the first bad parameter.
inline void validate(const MatcherParams& p) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("ScanMatcher: " + what); };
  auto positive = [&](double v, const char* name) {
    if (!(std::isfinite(v) && v > 0))
      fail(std::string(name) + " must be a positive number, got " + std::to_string(v));
  };
  positive(p.search_xy_m, "search_xy_m");
  positive(p.grid_resolution_m, "grid_resolution_m");
  positive(p.coarse_resolution_m, "coarse_resolution_m");
  positive(p.coarse_yaw_step_rad, "coarse_yaw_step_rad");
  positive(p.sigma_m, "sigma_m");
  positive(p.max_correspondence_m, "max_correspondence_m");
  positive(p.normal_radius_m, "normal_radius_m");
  positive(p.huber_m, "huber_m");
  positive(p.inlier_m, "inlier_m");
  positive(p.degenerate_std_m, "degenerate_std_m");
  if (!(std::isfinite(p.search_yaw_rad) && p.search_yaw_rad >= 0 && p.search_yaw_rad <= M_PI))
    fail("search_yaw_rad must be in [0, pi], got " + std::to_string(p.search_yaw_rad));
  if (p.coarse_resolution_m < p.grid_resolution_m)
    fail("coarse_resolution_m must be >= grid_resolution_m");
  if (p.icp_iterations < 1) fail("icp_iterations must be >= 1");
  if (p.min_points < 3) fail("min_points must be >= 3 (three unknowns)");
  if (!(std::isfinite(p.degeneracy_ratio) && p.degeneracy_ratio >= 0 && p.degeneracy_ratio < 1))
    fail("degeneracy_ratio must be in [0, 1), got " + std::to_string(p.degeneracy_ratio));
  positive(p.max_range_m, "max_range_m");
  // The widest grid: the crop's diameter plus build_grid's padding (kernel, window, blocks).
  const double res = p.grid_resolution_m;
  const double pad = std::ceil(std::max({3.0 * std::max(p.sigma_m, res), p.max_correspondence_m,
                                         p.normal_radius_m}) / res) +
                     2.0 * (std::ceil(p.search_xy_m / res) + std::max(1.0, std::round(p.coarse_resolution_m / res)));
  const double side = std::ceil(2.0 * crop_radius_m(p, p.max_range_m) / res) + 1.0 + 2.0 * pad;
  if (side * side > static_cast<double>(kMaxGridCells))
    fail("max_range_m " + std::to_string(p.max_range_m) + " with search_xy_m " + std::to_string(p.search_xy_m) +
         " needs a grid of " + std::to_string(static_cast<long>(side)) + " cells a side, more than " +
         std::to_string(static_cast<long>(std::sqrt(static_cast<double>(kMaxGridCells)))) +
         ": a shorter max_range_m or a coarser grid_resolution_m");
}

// One matcher; its buffers are allocated by the first matches and reused by the next ones.
// Not thread-safe: one call at a time per instance.
class ScanMatcher {
 public:
  explicit ScanMatcher(const MatcherParams& p) : p_(p) { validate(p_); }
  const MatcherParams& params() const { return p_; }

  // scan: n (x, y) points in the scan's frame; reference: m (x, y) points in the map frame;
  // views: null, or for each reference point the (x, y) it was seen from (map frame; the
  // scan's own viewpoint is its frame's origin); all row-major and finite (the binding
  // checks). Scan points beyond max_range_m are left out. Not ok, with the reason, when a
  // side has fewer than min_points points, fewer than min_points pairs remain, ICP slides away
  // from the coarse pose or the pairs leave the pose unconstrained.
  MatchResult match(const double* scan, int n_all, const double* reference, int m, Pose2 guess,
                    const double* views = nullptr) {
    MatchResult out;
    scan_.clear();
    double reach = 0;  // farthest scan point used from the sensor
    for (int i = 0; i < n_all; ++i) {
      const Eigen::Vector2d q(scan[2 * i], scan[2 * i + 1]);
      if (q.norm() > p_.max_range_m) continue;
      scan_.push_back(q);
      reach = std::max(reach, q.norm());
    }
    const int n = static_cast<int>(scan_.size());
    if (n < p_.min_points)
      return failed("too few scan points within max_range_m: " + std::to_string(n) + " of " +
                    std::to_string(n_all) + " < " + std::to_string(p_.min_points));
    crop_reference(reference, views, m, guess, reach);
    if (static_cast<int>(ref_.size()) < p_.min_points)
      return failed("too few reference points near the guess: " + std::to_string(ref_.size()) +
                    " of " + std::to_string(m) + " < " + std::to_string(p_.min_points));
    build_grid();

    // 1. Olson: lookup grid, its block maxima, branch-and-bound search.
    build_lookup();
    build_block_max();
    int best_sum = 0;
    Pose2 pose = correlative_search(guess, &best_sum);
    out.response = best_sum / (255.0 * n);

    // 2. Degeneracy at the coarse pose: keep the guess along a direction the scan does not
    //    fix, let Gauss-Newton move the other two dimensions only.
    build_lines();
    Basis basis = Basis::Identity();
    Linearisation lin = linearise(pose);
    if (lin.used < p_.min_points) return too_few(lin);
    if (weak_direction(lin.H, &out.degenerate_direction)) {
      out.degenerate = true;
      basis = constrain(out.degenerate_direction, guess, &pose);
    }

    // 3. Censi: point-to-line ICP. A scan found degenerate only at the refined pose gets the
    //    same treatment and a second pass. The exhaustive search leaves the optimum within a
    //    cell and a yaw step of the coarse pose: ICP sliding farther is following wrong pairs.
    const Pose2 start = pose;
    if (!refine(&pose, basis, &out.iterations, &lin)) return too_few(lin);
    if (!out.degenerate && weak_direction(lin.H, &out.degenerate_direction)) {
      out.degenerate = true;
      basis = constrain(out.degenerate_direction, guess, &pose);
      if (!refine(&pose, basis, &out.iterations, &lin)) return too_few(lin);
    }
    const std::string slide = slide_failure(start, pose, out);
    if (!slide.empty()) return failed(slide);
    out.conditioning = conditioning(lin.H);

    // 4. Covariance from the Hessian, in the body frame.
    if (!covariance(lin, basis, pose.yaw, &out))
      return failed("singular Hessian: the pairs do not constrain the pose");

    pose.yaw = std::remainder(pose.yaw, 2.0 * M_PI);
    out.pose = pose;
    out.score = static_cast<double>(lin.inliers) / n;
    out.points_used = lin.used;
    out.ok = true;
    return out;
  }

 private:
  // Columns span the subspace Gauss-Newton moves in: the identity, or (across d, 0),
  // (0, 0, 1) and a zero column. 3 x 3 either way, so nothing is allocated.
  using Basis = Eigen::Matrix3d;

  // Sums of one Gauss-Newton linearisation at a pose.
  struct Linearisation {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();  // J^T W J
    Eigen::Vector3d g = Eigen::Vector3d::Zero();  // J^T W r
    double weighted_r2 = 0, weight_sum = 0;
    int used = 0, inliers = 0;
  };

  // A reference cell: the lookup grid cell of some reference points.
  struct RefCell {
    int cell;                 // index in the lookup grid
    int count = 0;            // its points, their sum and sum of outer products (grid frame)
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    Eigen::Matrix2d outer = Eigen::Matrix2d::Zero();
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();    // of its points (map frame)
    bool line = false;        // a line was fitted to the points of the cells around it
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // the line's centroid (map frame)
    Eigen::Vector2d normal = Eigen::Vector2d::Zero();  // the line's unit normal
    // With viewpoints, per face (0: seen from the side the normal points to, 1: the other):
    // the cell's own points (count, sum; grid frame), then the line's centroid over the cells
    // around it and whether that face has enough points (kMinLinePoints) to pair with.
    int face_count[2] = {0, 0};
    Eigen::Vector2d face_sum[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    Eigen::Vector2d face_centre[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    bool face[2] = {false, false};
  };

  struct Candidate {
    int bound, yaw, bx, by;   // upper bound of the score of block (bx, by) at yaw index yaw
  };

  static MatchResult failed(std::string why) {
    MatchResult r;
    r.failure = std::move(why);
    return r;
  }
  MatchResult too_few(const Linearisation& lin) const {
    return failed("too few point-to-line pairs: " + std::to_string(lin.used) + " < " +
                  std::to_string(p_.min_points));
  }

  double blur_m() const { return std::max(p_.sigma_m, p_.grid_resolution_m); }
  int cells(double metres) const {
    return static_cast<int>(std::ceil(metres / p_.grid_resolution_m - 1e-9));
  }
  int window_cells() const { return cells(p_.search_xy_m); }
  int block_cells() const {
    return std::max(1, static_cast<int>(std::lround(p_.coarse_resolution_m / p_.grid_resolution_m)));
  }
  int kernel_cells() const { return cells(3.0 * blur_m()); }

  // --------------------------------------------------------------- the reference
  // Keep the reference points a scan point could reach from anywhere in the search window
  // (plus ICP's slide and the pairing gate): the grid then spans the scan's surroundings, not
  // the whole map.
  void crop_reference(const double* reference, const double* views, int m, const Pose2& guess,
                      double reach) {
    const double r = crop_radius_m(p_, reach);
    const Eigen::Vector2d c(guess.x, guess.y);
    ref_.clear();
    ref_view_.clear();
    faces_ = views != nullptr;
    for (int j = 0; j < m; ++j) {
      const Eigen::Vector2d q(reference[2 * j], reference[2 * j + 1]);
      if ((q - c).squaredNorm() > r * r) continue;
      ref_.push_back(q);
      if (faces_) ref_view_.emplace_back(views[2 * j], views[2 * j + 1]);
    }
  }

  // The grid over the cropped reference, padded so that every lookup of the correlative search
  // is on it or, for a scan point beyond the padding, known to be empty (the padding, 2 (window
  // + block) cells, holds no reference cell and no kernel), and every splat stays on it.
  // Gathers the reference cells and their points' moments.
  void build_grid() {
    Eigen::Vector2d lo = ref_[0], hi = ref_[0];
    for (const auto& q : ref_) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    const double res = p_.grid_resolution_m;
    const int reach = std::max({kernel_cells(), cells(p_.max_correspondence_m),
                                cells(p_.normal_radius_m)});
    pad_ = reach + 2 * (window_cells() + block_cells());
    origin_ = lo - Eigen::Vector2d::Constant(pad_ * res);
    gw_ = static_cast<int>(std::ceil((hi.x() - lo.x()) / res)) + 1 + 2 * pad_;
    gh_ = static_cast<int>(std::ceil((hi.y() - lo.y()) / res)) + 1 + 2 * pad_;
    if (static_cast<long>(gw_) * gh_ > kMaxGridCells)
      throw std::invalid_argument(
          "ScanMatcher.match: the reference near the guess needs a grid of " + std::to_string(gw_) +
          " x " + std::to_string(gh_) + " cells, more than " + std::to_string(kMaxGridCells) +
          ": a coarser grid_resolution_m or a shorter scan range");
    const std::size_t size = static_cast<std::size_t>(gw_) * gh_;
    slot_.assign(size, -1);
    ref_cells_.clear();
    for (const auto& q : ref_) {
      const Eigen::Vector2d local = q - origin_;  // moments in the grid frame: small numbers
      const int c = cell_of(q);
      if (slot_[c] < 0) {
        slot_[c] = static_cast<int>(ref_cells_.size());
        ref_cells_.push_back(RefCell{c});
      }
      RefCell& rc = ref_cells_[slot_[c]];
      ++rc.count;
      rc.sum += local;
      rc.outer += local * local.transpose();
    }
  }

  // Index of the cell holding q, or -1 off the grid.
  int cell_of(const Eigen::Vector2d& q) const {
    const int ix = static_cast<int>(std::floor((q.x() - origin_.x()) / p_.grid_resolution_m));
    const int iy = static_cast<int>(std::floor((q.y() - origin_.y()) / p_.grid_resolution_m));
    if (ix < 0 || iy < 0 || ix >= gw_ || iy >= gh_) return -1;
    return iy * gw_ + ix;
  }

  // Offsets (in cells, as grid indices) of the disc of the given radius (m), with their squared
  // lengths in cells.
  void disc(double radius_m, std::vector<int>* offsets, std::vector<int>* d2) const {
    const int k = cells(radius_m);
    const double r2 = std::pow(radius_m / p_.grid_resolution_m, 2) + 1e-9;
    offsets->clear();
    if (d2) d2->clear();
    for (int dy = -k; dy <= k; ++dy)
      for (int dx = -k; dx <= k; ++dx)
        if (dx * dx + dy * dy <= r2) {
          offsets->push_back(dy * gw_ + dx);
          if (d2) d2->push_back(dx * dx + dy * dy);
        }
  }

  // --------------------------------------------------------------- 1. correlative search
  // Olson's lookup grid: 255 exp(-d^2 / 2 s^2), d the distance (cells) to the nearest reference
  // cell, s = max(sigma_m, one cell); a precomputed kernel of radius 3 s splatted with max
  // around every reference cell.
  void build_lookup() {
    const int k = kernel_cells();
    const double s = blur_m() / p_.grid_resolution_m;
    kernel_.clear();
    kernel_offsets_.clear();
    for (int dy = -k; dy <= k; ++dy)
      for (int dx = -k; dx <= k; ++dx) {
        kernel_offsets_.push_back(dy * gw_ + dx);
        kernel_.push_back(static_cast<std::uint8_t>(
            std::lround(255.0 * std::exp(-(dx * dx + dy * dy) / (2.0 * s * s)))));
      }
    lookup_.assign(slot_.size(), 0);
    for (const RefCell& rc : ref_cells_)
      for (std::size_t i = 0; i < kernel_.size(); ++i) {
        std::uint8_t& v = lookup_[rc.cell + kernel_offsets_[i]];
        v = std::max(v, kernel_[i]);
      }
  }

  // Low-resolution grid (Olson IV-B): block_max[c] = max of lookup over the cells c + (a, b),
  // 0 <= a, b < D, so that the score of any translation of a D x D block is at most the sum of
  // block_max at the block's first translation. Separable: a pass along rows, then columns.
  void build_block_max() {
    const int D = block_cells();
    rowmax_.assign(lookup_.size(), 0);
    block_max_.assign(lookup_.size(), 0);
    for (int y = 0; y < gh_; ++y)
      for (int x = 0; x < gw_; ++x) {
        std::uint8_t v = 0;
        for (int a = 0; a < D && x + a < gw_; ++a) v = std::max(v, lookup_[y * gw_ + x + a]);
        rowmax_[y * gw_ + x] = v;
      }
    for (int y = 0; y < gh_; ++y)
      for (int x = 0; x < gw_; ++x) {
        std::uint8_t v = 0;
        for (int b = 0; b < D && y + b < gh_; ++b) v = std::max(v, rowmax_[(y + b) * gw_ + x]);
        block_max_[y * gw_ + x] = v;
      }
  }

  // The best (dx, dy, dyaw) of the window's lattice around the guess: translations in steps of
  // one cell within +-search_xy_m, yaws in steps of coarse_yaw_step_rad within
  // +-search_yaw_rad. Of equal scores the one nearest the guess wins (translation, then yaw).
  Pose2 correlative_search(const Pose2& guess, int* best_sum) {
    const int W = window_cells(), D = block_cells();
    const int K = static_cast<int>(std::floor(p_.search_yaw_rad / p_.coarse_yaw_step_rad + 1e-9));
    const int nyaw = 2 * K + 1, nb = (2 * W + D) / D, n = static_cast<int>(scan_.size());
    const double res = p_.grid_resolution_m;
    // The scan rotated once per yaw, as cell indices: only points whose every lookup stays on
    // the grid (one beyond scores 0 at every offset: it only meets the empty padding).
    rotated_.resize(static_cast<std::size_t>(nyaw) * n);
    counts_.assign(nyaw, 0);
    for (int k = 0; k < nyaw; ++k) {
      const double yaw = guess.yaw + (k - K) * p_.coarse_yaw_step_rad;
      const double c = std::cos(yaw), s = std::sin(yaw);
      int* out = &rotated_[static_cast<std::size_t>(k) * n];
      for (const auto& pt : scan_) {
        const int ix = static_cast<int>(std::floor((c * pt.x() - s * pt.y() + guess.x - origin_.x()) / res));
        const int iy = static_cast<int>(std::floor((s * pt.x() + c * pt.y() + guess.y - origin_.y()) / res));
        if (ix < W || iy < W || ix > gw_ - W - D || iy > gh_ - W - D) continue;
        out[counts_[k]++] = iy * gw_ + ix;
      }
    }
    // The bound of every (yaw, block), best first.
    candidates_.clear();
    for (int k = 0; k < nyaw; ++k)
      for (int by = 0; by < nb; ++by)
        for (int bx = 0; bx < nb; ++bx)
          candidates_.push_back({sum(block_max_, k, (by * D - W) * gw_ + bx * D - W), k, bx, by});
    std::sort(candidates_.begin(), candidates_.end(),
              [](const Candidate& a, const Candidate& b) { return a.bound > b.bound; });
    // Branch and bound: open blocks while their bound reaches the best score.
    int best = -1, best_dx = 0, best_dy = 0, best_k = K;
    auto nearer = [&](int dx, int dy, int k) {
      const int r = dx * dx + dy * dy, rb = best_dx * best_dx + best_dy * best_dy;
      return r < rb || (r == rb && std::abs(k - K) < std::abs(best_k - K));
    };
    for (const Candidate& cand : candidates_) {
      if (cand.bound < best) break;
      for (int b = 0; b < D; ++b)
        for (int a = 0; a < D; ++a) {
          const int dx = cand.bx * D + a - W, dy = cand.by * D + b - W;
          if (dx > W || dy > W) continue;
          const int score = sum(lookup_, cand.yaw, dy * gw_ + dx);
          if (score > best || (score == best && nearer(dx, dy, cand.yaw)))
            best = score, best_dx = dx, best_dy = dy, best_k = cand.yaw;
        }
    }
    *best_sum = std::max(best, 0);
    return {guess.x + best_dx * res, guess.y + best_dy * res,
            guess.yaw + (best_k - K) * p_.coarse_yaw_step_rad};
  }

  // Sum of grid values over the scan rotated to yaw index k, shifted by `offset` cells.
  int sum(const std::vector<std::uint8_t>& grid, int k, int offset) const {
    const int* idx = &rotated_[static_cast<std::size_t>(k) * scan_.size()];
    int total = 0;
    for (int i = 0; i < counts_[k]; ++i) total += grid[idx[i] + offset];
    return total;
  }

  // --------------------------------------------------------------- lines and pairing
  // Each reference cell's line: a least-squares fit to the points of the reference cells within
  // normal_radius_m (their summed moments). Then every cell within max_correspondence_m of a
  // reference cell learns the nearest one (nearest_ holds its slot in ref_cells_).
  void build_lines() {
    disc(p_.normal_radius_m, &offsets_line_, nullptr);
    const double min_extent2 = std::pow(kMinLineExtent * p_.normal_radius_m, 2);
    for (RefCell& rc : ref_cells_) {
      int count = 0;
      Eigen::Vector2d s = Eigen::Vector2d::Zero();
      Eigen::Matrix2d ss = Eigen::Matrix2d::Zero();
      for (const int o : offsets_line_) {
        const int slot = slot_[rc.cell + o];
        if (slot < 0) continue;
        count += ref_cells_[slot].count;
        s += ref_cells_[slot].sum;
        ss += ref_cells_[slot].outer;
      }
      const Eigen::Vector2d mean = s / count;
      const Eigen::Matrix2d scatter = ss / count - mean * mean.transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig;
      eig.computeDirect(scatter);
      rc.line = count >= kMinLinePoints && eig.eigenvalues()(1) >= min_extent2 &&
                eig.eigenvalues()(0) <= kMaxLineSpread * eig.eigenvalues()(1);
      rc.mean = origin_ + rc.sum / rc.count;
      rc.centre = origin_ + mean;
      rc.normal = eig.eigenvectors().col(0);  // minor axis: across the line
    }
    if (faces_) build_faces();
    std::vector<int>& d2 = disc_d2_;
    disc(p_.max_correspondence_m, &offsets_, &d2);
    nearest_.assign(slot_.size(), -1);
    nearest_d2_.assign(slot_.size(), std::numeric_limits<int>::max());
    for (std::size_t s = 0; s < ref_cells_.size(); ++s)
      for (std::size_t i = 0; i < offsets_.size(); ++i) {
        const int c = ref_cells_[s].cell + offsets_[i];
        if (d2[i] < nearest_d2_[c]) nearest_d2_[c] = d2[i], nearest_[c] = static_cast<int>(s);
      }
  }

  // Each line's centroid per face. A reference point is on the face its ray meets: face 0 when
  // its ray (viewpoint to point) runs against its cell's normal, i.e. it was seen from the
  // side the normal points to. Neighbouring cells' faces are counted in the cell's own normal
  // (a neighbour whose normal points the other way has its faces swapped).
  void build_faces() {
    for (std::size_t j = 0; j < ref_.size(); ++j) {
      RefCell& rc = ref_cells_[slot_[cell_of(ref_[j])]];
      const int f = rc.normal.dot(ref_[j] - ref_view_[j]) < 0 ? 0 : 1;
      ++rc.face_count[f];
      rc.face_sum[f] += ref_[j] - origin_;
    }
    for (RefCell& rc : ref_cells_) {
      if (!rc.line) continue;
      int count[2] = {0, 0};
      Eigen::Vector2d sum[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
      for (const int o : offsets_line_) {
        const int slot = slot_[rc.cell + o];
        if (slot < 0) continue;
        const RefCell& nb = ref_cells_[slot];
        const int swap = nb.normal.dot(rc.normal) < 0 ? 1 : 0;
        for (int f = 0; f < 2; ++f) {
          count[f ^ swap] += nb.face_count[f];
          sum[f ^ swap] += nb.face_sum[f];
        }
      }
      for (int f = 0; f < 2; ++f) {
        rc.face[f] = count[f] >= kMinLinePoints;
        if (rc.face[f]) rc.face_centre[f] = origin_ + sum[f] / count[f];
      }
    }
  }

  // --------------------------------------------------------------- 2. point-to-line ICP
  // Residual of scan point p at pose (x, y, yaw): r = n . (R p + t - c), (c, n) the line of the
  // reference cell nearest R p + t; Jacobian dr/d(x, y, yaw) = (n_x, n_y, n . R' p), with
  // R' p = (-sin(yaw) p_x - cos(yaw) p_y, cos(yaw) p_x - sin(yaw) p_y); Huber weight
  // w = min(1, huber_m / |r|). A pair whose scan point lies farther than max_correspondence_m
  // from the reference cell's points (their mean) is dropped. A point whose nearest reference
  // cell has no line counts in the score when it lies within inlier_m of that mean.
  Linearisation linearise(const Pose2& pose) const {
    Linearisation lin;
    const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
    const double gate2 = p_.max_correspondence_m * p_.max_correspondence_m;
    for (const auto& pt : scan_) {
      const Eigen::Vector2d q(c * pt.x() - s * pt.y() + pose.x, s * pt.x() + c * pt.y() + pose.y);
      const int cell = cell_of(q);
      if (cell < 0 || nearest_[cell] < 0) continue;
      const RefCell& rc = ref_cells_[nearest_[cell]];
      const double d2 = (q - rc.mean).squaredNorm();
      if (!rc.line) {
        if (d2 <= p_.inlier_m * p_.inlier_m) ++lin.inliers;
        continue;
      }
      if (d2 > gate2) continue;
      Eigen::Vector2d centre = rc.centre;
      if (faces_) {   // the face this scan point's ray meets (the scan is seen from its frame's origin)
        const int f = rc.normal.dot(q - Eigen::Vector2d(pose.x, pose.y)) < 0 ? 0 : 1;
        if (!rc.face[f]) continue;
        centre = rc.face_centre[f];
      }
      const double r = rc.normal.dot(q - centre);
      const Eigen::Vector3d J(rc.normal.x(), rc.normal.y(),
                              rc.normal.dot(Eigen::Vector2d(-s * pt.x() - c * pt.y(),
                                                            c * pt.x() - s * pt.y())));
      const double w = std::abs(r) <= p_.huber_m ? 1.0 : p_.huber_m / std::abs(r);
      lin.H.noalias() += w * J * J.transpose();
      lin.g.noalias() += w * r * J;
      lin.weighted_r2 += w * r * r;
      lin.weight_sum += w;
      ++lin.used;
      if (std::abs(r) <= p_.inlier_m) ++lin.inliers;
    }
    return lin;
  }

  // Gauss-Newton in the subspace spanned by `basis`: steps B delta with
  // (B^T H B) delta = -B^T g, until a step is below kConverged* or icp_iterations are spent.
  // *lin is left as the linearisation at the final pose. False when pairs run short.
  bool refine(Pose2* pose, const Basis& basis, int* iterations, Linearisation* lin) const {
    for (int it = 0; it < p_.icp_iterations; ++it) {
      *lin = linearise(*pose);
      if (lin->used < p_.min_points) return false;
      const Eigen::Vector3d step =
          basis * reduced(lin->H, basis).ldlt().solve(-(basis.transpose() * lin->g));
      if (!step.allFinite()) break;
      pose->x += step(0);
      pose->y += step(1);
      pose->yaw += step(2);
      ++*iterations;
      if (std::hypot(step(0), step(1)) < kConvergedM && std::abs(step(2)) < kConvergedRad) break;
    }
    *lin = linearise(*pose);
    return lin->used >= p_.min_points;
  }

  // B^T H B with 1 on the diagonal of each zero column of B: invertible when H is on the
  // subspace, and B (that)^-1 B^T is the inverse on the subspace (the 1 meets zero columns).
  static Eigen::Matrix3d reduced(const Eigen::Matrix3d& H, const Basis& B) {
    Eigen::Matrix3d M = B.transpose() * H * B;
    for (int i = 0; i < 3; ++i)
      if (B.col(i).squaredNorm() == 0) M(i, i) = 1.0;
    return M;
  }
  static int dimensions(const Basis& B) {
    return static_cast<int>((B.colwise().squaredNorm().array() > 0).count());
  }

  // Why the match is refused when ICP moved the pose from the coarse pose `start` more than
  // max_correspondence_m (across the degenerate direction, if any: along it the pose was put
  // back on the guess) or more than max(kMaxSlideSteps yaw steps, kMinSlideRad); else "".
  std::string slide_failure(const Pose2& start, const Pose2& pose, const MatchResult& out) const {
    const Eigen::Vector2d moved(pose.x - start.x, pose.y - start.y);
    const Eigen::Vector2d& d = out.degenerate_direction;
    const double slid_m =
        out.degenerate ? std::abs(Eigen::Vector2d(-d.y(), d.x()).dot(moved)) : moved.norm();
    const double slid_rad = std::abs(std::remainder(pose.yaw - start.yaw, 2.0 * M_PI));
    if (slid_m <= p_.max_correspondence_m &&
        slid_rad <= std::max(kMaxSlideSteps * p_.coarse_yaw_step_rad, kMinSlideRad))
      return "";
    return "ICP slid " + std::to_string(slid_m) + " m, " + std::to_string(slid_rad) +
           " rad from the coarse pose: no consistent match";
  }

  // out->covariance: sigma^2 (B^T H B)^-1 on the refined subspace, plus degenerate_std_m^2
  // along the degenerate direction, in the map-frame parameters (x, y, yaw); then in the body
  // frame. A body-frame perturbation xi of the pose moves those parameters by G xi, with
  // G = diag(R(yaw), 1) (GTSAM's Pose2 retract to first order), so cov_body = G^T cov G.
  // False when the Hessian is singular on the subspace.
  bool covariance(const Linearisation& lin, const Basis& basis, double yaw,
                  MatchResult* out) const {
    const double dof = std::max(lin.weight_sum - dimensions(basis), 1.0);
    const double sigma2 = std::max(lin.weighted_r2 / dof, p_.sigma_m * p_.sigma_m);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(reduced(lin.H, basis));
    if (!(eig.eigenvalues()(0) > 1e-12 * eig.eigenvalues()(2))) return false;
    const Eigen::Matrix3d inverse = eig.eigenvectors() *
        eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
    Eigen::Matrix3d cov = basis * (sigma2 * inverse) * basis.transpose();
    if (out->degenerate) {
      const Eigen::Vector3d d(out->degenerate_direction.x(), out->degenerate_direction.y(), 0.0);
      cov += p_.degenerate_std_m * p_.degenerate_std_m * d * d.transpose();
    }
    Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
    G.topLeftCorner<2, 2>() << std::cos(yaw), -std::sin(yaw), std::sin(yaw), std::cos(yaw);
    cov = G.transpose() * cov * G;
    out->covariance = 0.5 * (cov + cov.transpose());
    return true;
  }

  // --------------------------------------------------------------- 3. degeneracy
  static double conditioning(const Eigen::Matrix3d& H) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig;
    eig.computeDirect(H.topLeftCorner<2, 2>());
    return eig.eigenvalues()(1) > 0 ? eig.eigenvalues()(0) / eig.eigenvalues()(1) : 0.0;
  }

  // True when l_min < degeneracy_ratio l_max for the eigenvalues of H's translational block;
  // *d is then the eigenvector of l_min (unit, its larger component positive: one sign for one
  // line).
  bool weak_direction(const Eigen::Matrix3d& H, Eigen::Vector2d* d) const {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig;
    eig.computeDirect(H.topLeftCorner<2, 2>());
    const Eigen::Vector2d l = eig.eigenvalues();  // ascending
    if (!(l(0) < p_.degeneracy_ratio * l(1))) return false;
    *d = eig.eigenvectors().col(0).normalized();
    if ((std::abs(d->x()) >= std::abs(d->y()) ? d->x() : d->y()) < 0) *d = -*d;
    return true;
  }

  // Put the pose back on the guess along d; return the basis of the other two dimensions
  // (translation across d, yaw).
  static Basis constrain(const Eigen::Vector2d& d, const Pose2& guess, Pose2* pose) {
    const double along = d.dot(Eigen::Vector2d(pose->x - guess.x, pose->y - guess.y));
    pose->x -= along * d.x();
    pose->y -= along * d.y();
    Basis basis = Basis::Zero();
    basis.block<2, 1>(0, 0) = Eigen::Vector2d(-d.y(), d.x());  // across d
    basis(2, 1) = 1.0;                                          // yaw
    return basis;
  }

  MatcherParams p_;
  // The current match's scan (its frame) and cropped reference (map frame).
  std::vector<Eigen::Vector2d> scan_, ref_;
  std::vector<Eigen::Vector2d> ref_view_;  // where each of ref_ was seen from (with faces_)
  bool faces_ = false;                      // viewpoints given: lines are centred per face
  // The grid: gw_ x gh_ cells of grid_resolution_m, row-major, cell (0, 0)'s corner at origin_.
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  int gw_ = 0, gh_ = 0, pad_ = 0;
  std::vector<int> slot_;              // per cell: its index in ref_cells_, or -1
  std::vector<RefCell> ref_cells_;
  std::vector<std::uint8_t> lookup_, rowmax_, block_max_, kernel_;
  std::vector<int> kernel_offsets_, offsets_, offsets_line_, disc_d2_;
  std::vector<int> nearest_, nearest_d2_;  // per cell: nearest reference cell's slot (or -1)
  // Correlative search: the scan's cell indices per yaw, their counts, the candidate blocks.
  std::vector<int> rotated_, counts_;
  std::vector<Candidate> candidates_;
};

}  // namespace turtlebot_recon::slam
