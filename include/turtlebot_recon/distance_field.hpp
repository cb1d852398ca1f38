// Exact Euclidean distance transform of a binary grid.
//
// P. F. Felzenszwalb and D. P. Huttenlocher, "Distance Transforms of Sampled Functions",
// Theory of Computing 8 (2012) 415-428. The squared Euclidean transform is separable:
// the 1-D transform DT(f)(q) = min_p ((q - p)^2 + f(p)) is the lower envelope of the
// parabolas rooted at every p; run it down every column of the binary "feature" function
// (0 on features, +inf elsewhere), then along every row of the result. Linear time in the
// number of cells, exact (no brushfire/chamfer approximation, cf. seed 001 §5).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace turtlebot_recon::planning {

// The 1-D transform with its workspace (allocated once, reused for every line).
class LowerEnvelope1D {
 public:
  explicit LowerEnvelope1D(int max_n)
      : v_(static_cast<size_t>(max_n) + 1), z_(static_cast<size_t>(max_n) + 2) {}

  // d[q] = min_p ((q - p)^2 + f[p]) for q in [0, n); f may hold +inf ("no feature here"),
  // and d is +inf everywhere when every f is.
  void operator()(const double* f, int n, double* d) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    int* v = v_.data();     // roots of the parabolas that form the lower envelope
    double* z = z_.data();  // parabola v[k] is lowest on [z[k], z[k + 1]]
    // Abscissa where the parabolas rooted at q and p (p < q) intersect.
    auto intersect = [f](int q, int p) {
      return ((f[q] + double(q) * q) - (f[p] + double(p) * p)) / (2.0 * (q - p));
    };

    // Step 1: build the lower envelope left to right, popping parabolas it hides.
    int k = -1;
    for (int q = 0; q < n; ++q) {
      if (f[q] == kInf) continue;  // no parabola where f is infinite
      if (k < 0) {
        k = 0;
        v[0] = q;
        z[0] = -kInf;
        z[1] = kInf;
        continue;
      }
      double s = intersect(q, v[k]);
      while (s <= z[k]) s = intersect(q, v[--k]);  // z[0] = -inf stops this at k = 0
      ++k;
      v[k] = q;
      z[k] = s;
      z[k + 1] = kInf;
    }
    if (k < 0) {
      std::fill(d, d + n, kInf);
      return;
    }

    // Step 2: read the envelope off at every sample.
    k = 0;
    for (int q = 0; q < n; ++q) {
      while (z[k + 1] < q) ++k;
      const double dq = q - v[k];
      d[q] = dq * dq + f[v[k]];
    }
  }

 private:
  std::vector<int> v_;
  std::vector<double> z_;
};

// Squared distance, in cells, from every cell centre to the nearest cell with mask != 0;
// +inf everywhere when there is none. Row-major (rows, cols) in and out. The values are
// integers, exact in float up to 2^24 (any distance below 4096 cells).
inline void squared_distance_cells(const std::uint8_t* mask, int rows, int cols, float* out) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const size_t ncols = static_cast<size_t>(cols);
  const int longest = std::max(rows, cols);
  LowerEnvelope1D transform(longest);
  std::vector<double> f(static_cast<size_t>(longest)), d(static_cast<size_t>(longest));

  // Pass 1: DT along each column of the feature function (0 on mask cells, +inf elsewhere).
  for (int c = 0; c < cols; ++c) {
    for (int r = 0; r < rows; ++r) f[r] = mask[r * ncols + c] ? 0.0 : kInf;
    transform(f.data(), rows, d.data());
    for (int r = 0; r < rows; ++r) out[r * ncols + c] = static_cast<float>(d[r]);
  }
  // Pass 2: DT along each row of the column result.
  for (int r = 0; r < rows; ++r) {
    float* row = out + r * ncols;
    for (int c = 0; c < cols; ++c) f[c] = row[c];
    transform(f.data(), cols, d.data());
    for (int c = 0; c < cols; ++c) row[c] = static_cast<float>(d[c]);
  }
}

// Euclidean distance in metres from every cell centre to the nearest cell with mask != 0
// (0 on those cells, +inf everywhere when there is none).
inline void distance_transform(const std::uint8_t* mask, int rows, int cols, double resolution_m,
                               float* out_m) {
  squared_distance_cells(mask, rows, cols, out_m);
  const size_t n = static_cast<size_t>(rows) * static_cast<size_t>(cols);
  for (size_t i = 0; i < n; ++i)
    out_m[i] = static_cast<float>(std::sqrt(static_cast<double>(out_m[i])) * resolution_m);
}

}  // namespace turtlebot_recon::planning
