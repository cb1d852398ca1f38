// The robot's oriented footprint on a grid: which obstacle cells a body at a lattice pose, or
// sweeping a lattice move, comes nearer to than a margin.
//
// The body is a box in the robot's frame (x forward, y left, origin base_footprint; the box
// need not be centred on it) or, for a round robot, a disc; either is a convex polygon P padded
// by a radius rho (a box: P = the box, rho = the margin; a disc: P = the point at the origin,
// rho = radius + margin). A region collides with an obstacle cell when the cell's square comes
// nearer than rho to P: the margin is measured to the obstacle's edge, never to its centre.
//
// Lattice poses sit on cell centres at fixed headings, so the set of cells a region meets is
// the same at every cell: a GridShape holds it once per heading, as offsets from the centre
// cell, with two radii for the quick answers of the distance field (clear for sure when the
// nearest obstacle is beyond the region's reach, blocked for sure when it lies inside the disc
// the region contains).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace turtlebot_recon::planning {

constexpr double kPi = 3.14159265358979323846;

struct Vec2 {
  double x, y;
};

// The body about base_footprint (metres). length_m = 0: round, of radius radius_m.
struct Footprint {
  double length_m = 0.0;    // box extent along x
  double width_m = 0.0;     // box extent along y
  double offset_x_m = 0.0;  // box centre ahead of base_footprint
  double radius_m = 0.105;  // circumscribed radius about base_footprint: the turning disc
  bool round() const { return length_m <= 0.0; }
};

// Throws std::invalid_argument ("<fn>: ...") naming the first bad field.
inline void validate(const Footprint& f, const std::string& fn) {
  auto fail = [&fn](const std::string& what) { throw std::invalid_argument(fn + ": " + what); };
  if (!(std::isfinite(f.radius_m) && f.radius_m > 0))
    fail("footprint radius_m must be > 0, got " + std::to_string(f.radius_m));
  if (!(std::isfinite(f.length_m) && std::isfinite(f.width_m) && f.length_m >= 0 &&
        f.width_m >= 0 && (f.length_m > 0) == (f.width_m > 0)))
    fail("footprint length_m and width_m must both be > 0 (a box) or both 0 (round)");
  if (!f.round() && !(std::fabs(f.offset_x_m) < 0.5 * f.length_m))
    fail("footprint offset_x_m (" + std::to_string(f.offset_x_m) +
         ") must put base_footprint inside the box (|offset| < length / 2)");
}

// ------------------------------------------------------------------ lattice headings

// Heading k of K: the direction of the lattice vector (dr, dc), counter-clockwise from +x
// (+col; row = y). Its angle is the vector's own (16 headings: 0, 26.6, 45, 63.4, 90, ...
// degrees), so a straight move along a heading ends exactly on a cell centre.
struct LatticeHeading {
  int dr, dc;      // the straight move's lattice vector (rows, columns)
  double yaw_rad;  // atan2(dr, dc), in (-pi, pi]
};

// The K = 4, 8 or 16 headings: the first quadrant's vectors as (dx, dy), (1,0); (1,0),(1,1);
// or (1,0),(2,1),(1,1),(1,2); then each turned by 90 degrees, three times.
inline std::vector<LatticeHeading> lattice_headings(int k) {
  std::vector<std::pair<int, int>> quadrant;
  if (k == 4) quadrant = {{1, 0}};
  else if (k == 8) quadrant = {{1, 0}, {1, 1}};
  else if (k == 16) quadrant = {{1, 0}, {2, 1}, {1, 1}, {1, 2}};
  else throw std::invalid_argument("lattice headings must be 4, 8 or 16, got " + std::to_string(k));
  std::vector<LatticeHeading> out;
  for (int turn = 0; turn < 4; ++turn) {
    for (auto [dx, dy] : quadrant) {
      for (int t = 0; t < turn; ++t) dx = -std::exchange(dy, dx);  // (dx, dy) -> (-dy, dx)
      out.push_back({dy, dx, std::atan2(static_cast<double>(dy), static_cast<double>(dx))});
    }
  }
  return out;
}

// The heading nearest to yaw (rad, any value); ties to the lower index.
inline int nearest_heading(const std::vector<LatticeHeading>& headings, double yaw_rad) {
  int nearest = 0;
  double least = std::numeric_limits<double>::infinity();
  for (int k = 0; k < static_cast<int>(headings.size()); ++k) {
    const double err = std::fabs(std::remainder(yaw_rad - headings[k].yaw_rad, 2.0 * kPi));
    if (err < least - 1e-12) {
      least = err;
      nearest = k;
    }
  }
  return nearest;
}

// ------------------------------------------------------------------ convex geometry

inline double point_segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  const double ux = b.x - a.x, uy = b.y - a.y, len2 = ux * ux + uy * uy;
  const double t = len2 > 0 ? std::clamp(((p.x - a.x) * ux + (p.y - a.y) * uy) / len2, 0.0, 1.0) : 0.0;
  const double dx = p.x - (a.x + t * ux), dy = p.y - (a.y + t * uy);
  return std::sqrt(dx * dx + dy * dy);
}

// (a - o) x (b - o): > 0 when b lies to the left of o -> a.
inline double cross(Vec2 o, Vec2 a, Vec2 b) {
  return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

// Whether segments ab and cd cross at a point inside both (touching is left to the distances).
inline bool segments_cross(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  return ((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0));
}

// Whether p lies in the counter-clockwise convex polygon (>= 3 vertices), boundary included.
inline bool inside_convex(Vec2 p, const std::vector<Vec2>& poly) {
  for (size_t i = 0; i < poly.size(); ++i)
    if (cross(poly[i], poly[(i + 1) % poly.size()], p) < 0) return false;
  return true;
}

// Distance between two convex sets given by their vertices (1: a point, 2: a segment, >= 3: a
// counter-clockwise polygon); 0 when they touch or overlap. Two disjoint convex sets are
// nearest between a vertex of one and an edge of the other; overlapping ones have a vertex
// inside the other or two crossing edges.
inline double convex_distance(const std::vector<Vec2>& a, const std::vector<Vec2>& b) {
  if (a.size() >= 3)
    for (Vec2 p : b)
      if (inside_convex(p, a)) return 0.0;
  if (b.size() >= 3)
    for (Vec2 p : a)
      if (inside_convex(p, b)) return 0.0;
  // Edge i runs from vertex i to the next; a point is one edge to itself, a segment one edge.
  auto edges = [](const std::vector<Vec2>& v) { return v.size() >= 3 ? v.size() : size_t{1}; };
  auto next = [](const std::vector<Vec2>& v, size_t i) { return (i + 1) % v.size(); };
  double least = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < edges(a); ++i) {
    const Vec2 p = a[i], q = a[next(a, i)];
    for (size_t j = 0; j < edges(b); ++j) {
      const Vec2 r = b[j], s = b[next(b, j)];
      if (segments_cross(p, q, r, s)) return 0.0;
      least = std::min({least, point_segment_distance(p, r, s), point_segment_distance(q, r, s),
                        point_segment_distance(r, p, q), point_segment_distance(s, p, q)});
    }
  }
  return least;
}

// ------------------------------------------------------------------ regions on the grid

// A convex polygon about the robot's reference point (robot frame, metres) padded by rho.
struct Region {
  std::vector<Vec2> polygon;  // counter-clockwise; 1 vertex: a point, 2: a segment
  double rho;                 // padding (m), > 0
};

// The box [x0, x1] x [y0, y1] of the robot frame, counter-clockwise; a segment or a point when
// it has no width or no extent at all (what a round robot's body sweeps, or its body).
inline std::vector<Vec2> box_polygon(double x0, double x1, double y0, double y1) {
  if (y0 == y1) return x0 == x1 ? std::vector<Vec2>{{x0, y0}} : std::vector<Vec2>{{x0, y0}, {x1, y0}};
  return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
}

// The cells that a union of regions, turned to one heading, meets when the robot's reference
// point sits on a cell centre; as index offsets into a grid whose rows are `stride` apart.
//
// clear() answers in three steps, d being the distance (cells, centre to centre) from the
// reference cell to the nearest obstacle cell (the distance field), h half a cell:
//   1. d >= r_out + h sqrt 2: every obstacle square lies beyond the region's farthest reach
//      (r_out: the farthest vertex + rho): clear;
//   2. d < r_in + h: the nearest obstacle square reaches within r_in of the centre, inside the
//      disc the region contains (r_in: rho + the centre's distance to the polygon's edges):
//      blocked;
//   3. otherwise test the cells, skipping those nearer than step 2's bound (no obstacle there).
class GridShape {
 public:
  GridShape() = default;

  // regions: robot frame; yaw_rad: the heading; res: the cell size (m); stride: row length.
  GridShape(const std::vector<Region>& regions, double yaw_rad, double res, int stride) {
    const double c = std::cos(yaw_rad), s = std::sin(yaw_rad), h = 0.5 * res;
    std::vector<std::vector<Vec2>> turned;
    std::vector<double> reach_of;  // each region's farthest reach from the centre
    for (const Region& region : regions) {
      std::vector<Vec2> poly;
      double farthest = 0.0;
      for (Vec2 v : region.polygon) {
        poly.push_back({c * v.x - s * v.y, s * v.x + c * v.y});
        farthest = std::max(farthest, std::hypot(v.x, v.y));
      }
      reach_of.push_back(region.rho + farthest);
      double inner = 0.0;  // the centre's distance to the polygon's boundary, if inside it
      if (poly.size() >= 3 && inside_convex({0, 0}, poly)) {
        inner = std::numeric_limits<double>::infinity();
        for (size_t i = 0; i < poly.size(); ++i)
          inner = std::min(inner, point_segment_distance({0, 0}, poly[i], poly[(i + 1) % poly.size()]));
      }
      r_in_m_ = std::max(r_in_m_, region.rho + inner);
      r_out_m_ = std::max(r_out_m_, region.rho + farthest);
      turned.push_back(std::move(poly));
    }
    accept_d2_ = square((r_out_m_ + std::sqrt(2.0) * h) / res);
    reject_d2_ = square((r_in_m_ + h) / res);

    // Every cell whose square comes nearer than rho to some region's polygon (a region whose
    // reach the square lies beyond is skipped).
    reach_ = static_cast<int>(std::ceil((r_out_m_ + std::sqrt(2.0) * h) / res));
    std::vector<std::pair<int, std::int64_t>> hits;  // (squared distance, offset)
    for (int dr = -reach_; dr <= reach_; ++dr) {
      for (int dc = -reach_; dc <= reach_; ++dc) {
        const double x = dc * res, y = dr * res, nearest = std::hypot(x, y) - std::sqrt(2.0) * h;
        const std::vector<Vec2> cell{{x - h, y - h}, {x + h, y - h}, {x + h, y + h}, {x - h, y + h}};
        bool meets = false;
        for (size_t i = 0; i < regions.size() && !meets; ++i)
          meets = nearest < reach_of[i] && convex_distance(cell, turned[i]) < regions[i].rho;
        if (meets) hits.push_back({dr * dr + dc * dc, static_cast<std::int64_t>(dr) * stride + dc});
      }
    }
    std::sort(hits.begin(), hits.end());
    for (auto [d2, offset] : hits) {
      if (d2 < reject_d2_) ++first_unsure_;
      offsets_.push_back(offset);
    }
  }

  // Whether the region at padded cell `centre` is clear of the cells with obstacle != 0;
  // d2: squared distance (cells) from `centre` to the nearest obstacle cell.
  bool clear(const std::uint8_t* obstacle, std::int64_t centre, float d2) const {
    if (d2 >= accept_d2_) return true;   // 1. beyond reach
    if (d2 < reject_d2_) return false;   // 2. inside the contained disc
    for (size_t j = first_unsure_; j < offsets_.size(); ++j)  // 3. the cells themselves
      if (obstacle[centre + offsets_[j]]) return false;
    return true;
  }

  double r_in_m() const { return r_in_m_; }    // radius of the disc the region contains
  double r_out_m() const { return r_out_m_; }  // radius of the disc that contains the region
  int reach_cells() const { return reach_; }   // no offset is farther than this along an axis
  double reject_d2() const { return reject_d2_; }  // step 2: d2 below this is blocked

 private:
  static double square(double v) { return v * v; }

  std::vector<std::int64_t> offsets_;  // by distance from the centre
  size_t first_unsure_ = 0;            // offsets_[0, first_unsure_) lie inside step 2's bound
  double r_in_m_ = 0, r_out_m_ = 0, accept_d2_ = 0, reject_d2_ = 0;
  int reach_ = 0;
};

// ------------------------------------------------------------------ any pose

// The body at an arbitrary pose in grid coordinates: the polygon (1 vertex for a round robot)
// and its padding (a round robot: its radius, plus `pad`; a box: `pad`).
inline std::pair<std::vector<Vec2>, double> body_at(const Footprint& fp, double pad, double x,
                                                     double y, double yaw) {
  if (fp.round()) return {{{x, y}}, fp.radius_m + pad};
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double x0 = fp.offset_x_m - 0.5 * fp.length_m, x1 = fp.offset_x_m + 0.5 * fp.length_m;
  std::vector<Vec2> body;
  for (Vec2 v : box_polygon(x0, x1, -0.5 * fp.width_m, 0.5 * fp.width_m))
    body.push_back({x + c * v.x - s * v.y, y + s * v.x + c * v.y});
  return {body, pad};
}

// Calls visit(row, col, distance) for every obstacle cell whose square comes nearer than
// `reach` to the body at (x, y, yaw) (distance: body to square, 0 when they meet); stops early
// when visit returns false. (x, y): metres from the grid's corner (cell (0, 0) spans [0, res] x
// [0, res]); is_obstacle(row, col) answers for any cell, on the grid or off it. Tests exactly
// every cell under the body's bounding box grown by `reach`.
template <class IsObstacle, class Visit>
void for_each_obstacle_near(const Footprint& fp, double reach, double res, double x, double y,
                            double yaw, IsObstacle&& is_obstacle, Visit&& visit) {
  const auto [body, rho] = body_at(fp, reach, x, y, yaw);
  const double inflate = rho - reach;  // a round body's radius: its distance is to the disc
  double lo_x = body[0].x, hi_x = lo_x, lo_y = body[0].y, hi_y = lo_y;
  for (Vec2 v : body) {
    lo_x = std::min(lo_x, v.x), hi_x = std::max(hi_x, v.x);
    lo_y = std::min(lo_y, v.y), hi_y = std::max(hi_y, v.y);
  }
  auto cell_of = [res](double v) { return static_cast<int>(std::floor(v / res)); };
  for (int r = cell_of(lo_y - rho); r <= cell_of(hi_y + rho); ++r) {
    for (int c = cell_of(lo_x - rho); c <= cell_of(hi_x + rho); ++c) {
      if (!is_obstacle(r, c)) continue;
      const double sx = c * res, sy = r * res;
      const std::vector<Vec2> cell{{sx, sy}, {sx + res, sy}, {sx + res, sy + res}, {sx, sy + res}};
      const double d = convex_distance(cell, body);
      if (d < rho && !visit(r, c, std::max(d - inflate, 0.0))) return;
    }
  }
}

// Whether the body at an arbitrary pose keeps `margin` off every obstacle cell's square: for
// poses off the lattice (a controller's look-ahead); arguments as for_each_obstacle_near.
template <class IsObstacle>
bool footprint_clear_at(const Footprint& fp, double margin, double res, double x, double y,
                        double yaw, IsObstacle&& is_obstacle) {
  bool clear = true;
  for_each_obstacle_near(fp, margin, res, x, y, yaw, is_obstacle, [&](int, int, double) {
    return clear = false;
  });
  return clear;
}

// The distance (m) from the body at an arbitrary pose to the nearest obstacle cell's square, 0
// when they meet, `max_m` when none is nearer than that; arguments as for_each_obstacle_near.
template <class IsObstacle>
double footprint_clearance_at(const Footprint& fp, double max_m, double res, double x, double y,
                              double yaw, IsObstacle&& is_obstacle) {
  double least = max_m;
  for_each_obstacle_near(fp, max_m, res, x, y, yaw, is_obstacle, [&](int, int, double d) {
    least = std::min(least, d);
    return least > 0.0;
  });
  return least;
}

}  // namespace turtlebot_recon::planning
