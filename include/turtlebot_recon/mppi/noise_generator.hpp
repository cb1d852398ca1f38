// MPPI's exploration noise: independent Gaussian perturbations of v and w at every step of
// every rollout, eps ~ N(0, diag(std_v^2, std_w^2)), from a seeded std::mt19937_64 (the same
// seed gives the same noise, hence the same commands).
//
// Drawn every `knot_steps` steps and interpolated linearly between (knot_steps = 1: white
// noise, Nav2's): white noise at 0.05 s averages out within a few steps, the heading of a
// rollout then wanders by only std_w dt sqrt(T) (0.15 rad over 56 steps at 0.4 rad/s), and no
// rollout looks around an obstacle; knots 0.2 s apart sample whole swerves (and cost a quarter
// of the draws). Between knots the variance dips to half of std^2 at the midpoint.
//
// Box-Muller on whole arrays: two uniforms u1 in (0, 1], u2 in [0, 1) per (rollout, step),
// 24 bits each from one 64-bit word, give the pair r cos(2 pi u2), r sin(2 pi u2) with
// r = sqrt(-2 ln u1), one for v and one for w; log, sqrt, cos and sin then run vectorised over
// the batch (std::normal_distribution draws twice the words and runs its maths one by one).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <stdexcept>

#include "turtlebot_recon/mppi/motion_model.hpp"

namespace turtlebot_recon::mppi {

class NoiseGenerator {
 public:
  NoiseGenerator() = default;
  NoiseGenerator(double std_v_mps, double std_w_radps, int knot_steps, std::uint32_t seed)
      : std_v_(static_cast<float>(std_v_mps)), std_w_(static_cast<float>(std_w_radps)),
        knot_steps_(knot_steps) {
    if (!(std_v_mps >= 0 && std_w_radps >= 0))
      throw std::invalid_argument("NoiseGenerator: noise std must be >= 0");
    if (knot_steps < 1) throw std::invalid_argument("NoiseGenerator: knot_steps must be >= 1");
    reseed(seed);
  }

  void reseed(std::uint32_t seed) { rng_.seed(seed); }

  // Fills eps_v and eps_w [batch x T] (already sized) with fresh noise.
  void sample(Array& eps_v, Array& eps_w) {
    const Eigen::Index K = eps_v.rows(), T = eps_v.cols();
    if (knot_steps_ == 1) return gaussian(eps_v, eps_w);
    const Eigen::Index knots = (T - 1) / knot_steps_ + 2;  // the last knot at or past T - 1
    knot_v_.resize(K, knots);
    knot_w_.resize(K, knots);
    gaussian(knot_v_, knot_w_);
    for (Eigen::Index t = 0; t < T; ++t) {
      const Eigen::Index j = t / knot_steps_;
      const float f = static_cast<float>(t % knot_steps_) / knot_steps_;
      eps_v.col(t) = (1.0f - f) * knot_v_.col(j) + f * knot_v_.col(j + 1);
      eps_w.col(t) = (1.0f - f) * knot_w_.col(j) + f * knot_w_.col(j + 1);
    }
  }

 private:
  // Box-Muller: fills a and b (the same size) with N(0, std_v^2) and N(0, std_w^2).
  void gaussian(Array& eps_v, Array& eps_w) {
    constexpr float kScale = 1.0f / 16777216.0f;  // 24 random bits -> [0, 1)
    constexpr float kTwoPi = 6.28318530717958647692f;
    const Eigen::Index n = eps_v.size();
    float* u1 = eps_v.data();  // the uniforms go where the normals will be
    float* u2 = eps_w.data();
    for (Eigen::Index i = 0; i < n; ++i) {
      const std::uint64_t bits = rng_();
      u1[i] = (static_cast<float>(bits >> 40) + 1.0f) * kScale;  // (0, 1]: the log is finite
      u2[i] = static_cast<float>((bits >> 8) & 0xFFFFFFu) * kScale;
    }
    radius_ = (-2.0f * eps_v.log()).sqrt();
    angle_ = kTwoPi * eps_w;
    eps_v = std_v_ * radius_ * angle_.cos();
    eps_w = std_w_ * radius_ * angle_.sin();
  }

  float std_v_ = 0.2f, std_w_ = 0.4f;
  int knot_steps_ = 1;
  std::mt19937_64 rng_{0};
  Array knot_v_, knot_w_, radius_, angle_;  // scratch, allocated on first use and kept
};

}  // namespace turtlebot_recon::mppi
