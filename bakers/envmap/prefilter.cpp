#include "bakers/envmap/prefilter.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"

namespace kiln::envmap {
namespace {

constexpr int kGroups = 4;  // independent randomised groups for the error estimate

double radical_inverse_base2(uint32_t i) {
  i = (i << 16u) | (i >> 16u);
  i = ((i & 0x55555555u) << 1u) | ((i & 0xAAAAAAAAu) >> 1u);
  i = ((i & 0x33333333u) << 2u) | ((i & 0xCCCCCCCCu) >> 2u);
  i = ((i & 0x0F0F0F0Fu) << 4u) | ((i & 0xF0F0F0F0u) >> 4u);
  i = ((i & 0x00FF00FFu) << 8u) | ((i & 0xFF00FF00u) >> 8u);
  return static_cast<double>(i) * 0x1.0p-32;
}

// Point i of the M-point Hammersley set, Cranley–Patterson rotated by `shift` (mod 1).
Point2 hammersley(int i, int m, Point2 shift) {
  double x = (i + 0.5) / m + shift.x, y = radical_inverse_base2(static_cast<uint32_t>(i)) + shift.y;
  x -= std::floor(x);
  y -= std::floor(y);
  return {x, y};
}

// Trilinear read of the mip chain at fractional level `lod` (clamped to the chain).
Rgb sample_trilinear(const std::vector<Cubemap>& mips, const Vec3& dir, double lod) {
  const double top = static_cast<double>(mips.size() - 1);
  lod = std::clamp(lod, 0.0, top);
  const int l0 = static_cast<int>(std::floor(lod));
  const double t = lod - l0;
  const Rgb a = mips[l0].sample_bilinear(dir);
  if (t == 0.0 || l0 + 1 >= static_cast<int>(mips.size())) return a;
  return lerp(t, a, mips[l0 + 1].sample_bilinear(dir));
}

template <class Fn>
void for_each_texel(int size, Fn&& fn) {
  const int per_face = size * size;
  tbb::parallel_for(tbb::blocked_range<int>(0, kFaceCount * per_face), [&](const tbb::blocked_range<int>& r) {
    for (int idx = r.begin(); idx != r.end(); ++idx) {
      const int face = idx / per_face, rem = idx % per_face;
      fn(face, rem % size, rem / size, idx);
    }
  });
}

}  // namespace

double prefilter_level_roughness(int level, int levels) {
  // A single level has no rough end: it is the mirror (avoids 0/0).
  if (levels <= 1) return 0.0;
  return static_cast<double>(level) / (levels - 1);
}

std::vector<Cubemap> build_source_mips(const Cubemap& source) {
  std::vector<Cubemap> mips{source};
  while (mips.back().size() > 1 && mips.back().size() % 2 == 0) mips.push_back(downsample_2x(mips.back()));
  return mips;
}

Cubemap prefilter_level(const std::vector<Cubemap>& mips, int out_size, double rho, int samples,
                        double* error_estimate) {
  if (mips.empty() || mips[0].size() < 1) throw std::invalid_argument("prefilter_level: empty source");
  if (out_size < 1 || samples < 1) throw std::invalid_argument("prefilter_level: out_size and samples must be >= 1");
  const int per_group = (samples + kGroups - 1) / kGroups;
  const int n_total = per_group * kGroups;
  Cubemap out(out_size);
  std::vector<double> rel_var(static_cast<size_t>(kFaceCount) * out_size * out_size, 0.0);

  // ρ = 0: D is a delta; the lobe is the mirror direction itself (no sampling, no error).
  if (rho <= 0.0) {
    for_each_texel(out_size, [&](int f, int x, int y, int) {
      out.at(f, x, y) = mips[0].sample_bilinear(texel_direction(f, x, y, out_size));
    });
    if (error_estimate) *error_estimate = 0.0;
    return out;
  }

  const double alpha = rho * rho;
  const brdf::MicrofacetDistribution dist(brdf::Distribution::ggx, alpha, alpha);
  const int size0 = mips[0].size();
  const double omega_p = 4.0 * kPi / (6.0 * size0 * size0);  // solid angle of one level-0 source texel (average)

  // The sample pattern in the local frame (normal +z, v = +z) is the same for every texel: precompute l, n·l, lod.
  struct Sample { Vec3 l; double nl; double lod; };
  std::array<std::vector<Sample>, kGroups> pattern;
  Pcg32 rng(0x9e3779b97f4a7c15ULL, 0x6a09e667f3bcc909ULL);
  const Vec3 v{0, 0, 1};
  for (int g = 0; g < kGroups; ++g) {
    const Point2 shift{rng.uniform(), rng.uniform()};
    for (int i = 0; i < per_group; ++i) {
      const Vec3 h = dist.sample_wh(v, hammersley(i, per_group, shift));
      const double vh = dot(v, h);
      const Vec3 l = h * (2.0 * vh) - v;
      // Below the horizon (n·l ≤ 0) the weight is zero; vh ≤ 0 would make p(l) singular — neither contributes.
      if (l.z <= 0.0 || vh <= 0.0) continue;
      const double pdf_l = dist.pdf_wh(v, h) / (4.0 * vh);
      // A zero density (numerically, far in the tail) would give an infinite Ω_s: read the coarsest level.
      const double lod = pdf_l > 0.0 ? 0.5 * std::log2(1.0 / (n_total * pdf_l) / omega_p) + 1.0 : 1e9;
      pattern[g].push_back({l, l.z, lod});
    }
  }

  for_each_texel(out_size, [&](int f, int x, int y, int idx) {
    const Vec3 n = texel_direction(f, x, y, out_size);
    const Frame frame = Frame::from_normal(n);
    Rgb sum_all;
    double w_all = 0.0;
    std::array<double, kGroups> group_mean{};
    for (int g = 0; g < kGroups; ++g) {
      Rgb sum;
      double w = 0.0;
      for (const Sample& s : pattern[g]) {
        sum += sample_trilinear(mips, frame.from_local(s.l), s.lod) * s.nl;
        w += s.nl;
      }
      sum_all += sum;
      w_all += w;
      // A group with no sample above the horizon (cannot happen for N/4 ≥ 1 with GGX, guarded anyway) reads 0.
      group_mean[g] = w > 0.0 ? (sum / w).average() : 0.0;
    }
    const Rgb value = w_all > 0.0 ? sum_all / w_all : Rgb{};
    out.at(f, x, y) = value;
    double mean = 0.0;
    for (double m : group_mean) mean += m / kGroups;
    double var = 0.0;
    for (double m : group_mean) var += (m - mean) * (m - mean) / (kGroups - 1);
    const double se2 = var / kGroups;  // variance of the mean of the groups
    const double denom = std::abs(value.average());
    // A zero (black) texel has no relative error; its absolute error is then 0 too unless the groups disagree.
    rel_var[idx] = denom > 0.0 ? se2 / (denom * denom) : 0.0;
  });
  if (error_estimate) {
    double acc = 0.0;
    for (double r : rel_var) acc += r;
    *error_estimate = std::sqrt(acc / rel_var.size());
  }
  return out;
}

std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& source, int out_size, const PrefilterOptions& opt) {
  if (source.size() < 1) throw std::invalid_argument("prefilter_specular: empty source");
  if (out_size < 1) throw std::invalid_argument("prefilter_specular: out_size must be >= 1");
  if (opt.levels < 1) throw std::invalid_argument("prefilter_specular: levels must be >= 1");
  if (opt.samples < 1) throw std::invalid_argument("prefilter_specular: samples must be >= 1");
  const std::vector<Cubemap> mips = build_source_mips(source);
  std::vector<PrefilteredLevel> chain;
  for (int k = 0; k < opt.levels; ++k) {
    PrefilteredLevel level;
    level.roughness = prefilter_level_roughness(k, opt.levels);
    const int size = std::max(1, out_size >> k);
    if (k == 0) {
      // Mirror: the source's own mip of that size if there is one (area-correct), else bilinear resampling.
      const auto it = std::find_if(mips.begin(), mips.end(), [&](const Cubemap& c) { return c.size() == size; });
      level.cube = it != mips.end() ? *it : prefilter_level(mips, size, 0.0, 1);
    } else {
      level.cube = prefilter_level(mips, size, level.roughness, opt.samples, &level.error_estimate);
    }
    chain.push_back(std::move(level));
  }
  return chain;
}

Cubemap brute_force_prefilter(const Cubemap& src, int out_size, double roughness, int subdivisions) {
  if (src.size() < 1 || out_size < 1 || subdivisions < 1)
    throw std::invalid_argument("brute_force_prefilter: sizes and subdivisions must be >= 1");
  Cubemap out(out_size);
  // ρ = 0: D is a delta, the lobe is the mirror direction.
  if (roughness <= 0.0) {
    for_each_texel(out_size, [&](int f, int x, int y, int) {
      out.at(f, x, y) = src.sample_bilinear(texel_direction(f, x, y, out_size));
    });
    return out;
  }
  const double alpha = roughness * roughness;
  const brdf::MicrofacetDistribution dist(brdf::Distribution::ggx, alpha, alpha);
  const int ns = src.size(), k = subdivisions;
  // Every (sub-)texel's direction, solid angle and radiance, once.
  struct Texel { Vec3 l; double omega; Rgb radiance; };
  std::vector<Texel> texels;
  texels.reserve(static_cast<size_t>(kFaceCount) * ns * ns * k * k);
  const double step = 2.0 / (ns * k);
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < ns; ++y)
      for (int x = 0; x < ns; ++x) {
        if (k == 1) {
          texels.push_back({texel_direction(f, x, y, ns), texel_solid_angle(x, y, ns), src.at(f, x, y)});
          continue;
        }
        for (int j = 0; j < k; ++j)
          for (int i = 0; i < k; ++i) {
            const double a0 = -1.0 + (x * k + i) * step, b0 = -1.0 + (y * k + j) * step;
            const Vec3 l = normalize(face_uv_to_direction(f, (a0 + 0.5 * step + 1.0) / 2.0,
                                                          (b0 + 0.5 * step + 1.0) / 2.0));
            texels.push_back({l, face_rect_solid_angle(a0, b0, a0 + step, b0 + step), src.sample_bilinear(l)});
          }
      }
  for_each_texel(out_size, [&](int f, int x, int y, int) {
    const Vec3 n = texel_direction(f, x, y, out_size);
    const Frame frame = Frame::from_normal(n);
    Rgb sum;
    double w = 0.0;
    for (const Texel& t : texels) {
      const double nl = dot(n, t.l);
      if (nl <= 0.0) continue;  // below the horizon of n: zero weight (also excludes l = −n, where h is undefined)
      const Vec3 h = normalize(n + t.l);
      const double weight = dist.D(frame.to_local(h)) * nl * t.omega;
      sum += t.radiance * weight;
      w += weight;
    }
    // Every n has source texels with n·l > 0 and D > 0 for α > 0, so w > 0; guarded for safety.
    out.at(f, x, y) = w > 0.0 ? sum / w : Rgb{};
  });
  return out;
}

}  // namespace kiln::envmap
