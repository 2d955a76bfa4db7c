// The phase function where several media overlap: each channel c scatters by Σ_i sigma_s_i[c]·p_i / Σ_i
// sigma_s_i[c], a mixture of Henyey–Greenstein lobes whose weights differ per channel. Sampling picks lobe i with
// probability q_i ∝ max_c of its weight and samples it; the pdf of a direction is Σ q_i p_i, and the per-channel
// value over that pdf is the sample's weight: unbiased in every channel. With one lobe it is that lobe exactly.
#pragma once

#include <array>

#include "bakers/math/rgb.h"
#include "bakers/volume/henyey_greenstein.h"

namespace kiln::volume {

class PhaseMixture {
 public:
  static constexpr int kMaxLobes = 16;  // bounds::kLightmapMedia.hi

  // Adds the lobe of a medium with asymmetry g and scattering coefficient sigma_s at the point (skipped when 0).
  void add(double g, const Rgb& sigma_s);
  // After the last add: normalises the weights. False if no lobe scatters (nothing to sample).
  bool finish();

  // The phase function per channel for (wo, wi), and the density sample() draws wi with.
  Rgb p(const Vec3& wo, const Vec3& wi) const;
  double pdf(const Vec3& wo, const Vec3& wi) const;

  struct Sample {
    Vec3 wi;
    Rgb weight;  // p / pdf per channel
    double pdf = 0;
  };
  // u uniform on [0, 1)³: u0 picks the lobe, (u1, u2) the direction.
  Sample sample(const Vec3& wo, double u0, Point2 u) const;

 private:
  HenyeyGreenstein lobe(int i) const { return HenyeyGreenstein(g_[i]); }

  int n_ = 0;
  std::array<double, kMaxLobes> g_{};
  std::array<Rgb, kMaxLobes> weight_;  // sigma_s_i per channel, then over the channel's sum
  std::array<double, kMaxLobes> q_{};  // the lobe's choice probability
};

}  // namespace kiln::volume
