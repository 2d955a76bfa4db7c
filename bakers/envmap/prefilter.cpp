#include "bakers/envmap/prefilter.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bakers/envmap/level_sampler.h"
#include "bakers/envmap/lobe.h"
#include "bakers/envmap/sun.h"

namespace kiln::envmap {
namespace {

constexpr int kPilotSamples = 64;                  // the first trial when choosing N
constexpr int kMaxTrials = 6;                      // trials when choosing N
constexpr double kStepMargin = 1.2;                // N is scaled by (e/target)² times this
constexpr double kReferenceTexelsPerAlpha = 16.0;  // reference mip size ≥ this / α (box filter ≤ 1/16 of the lobe)

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

// The sampler's estimates at normal(0 .. count), each handed to store(i, value, relative variance), kSamplerLanes
// at a time, in parallel (TBB) over blocks; a set cancel flag skips the remaining blocks.
template <class Normal, class Store>
void eval_in_lanes(const LevelSampler& sampler, int count, Normal&& normal, Store&& store, bool with_rel_var,
                   const std::atomic<bool>* cancel) {
  const int blocks = (count + kSamplerLanes - 1) / kSamplerLanes;
  tbb::parallel_for(tbb::blocked_range<int>(0, blocks), [&](const tbb::blocked_range<int>& r) {
    for (int b = r.begin(); b != r.end(); ++b) {
      if (cancel && cancel->load()) return;  // stop early: the chain is discarded
      const int first = b * kSamplerLanes, lanes = std::min(kSamplerLanes, count - first);
      std::array<Vec3, kSamplerLanes> n;
      std::array<Rgb, kSamplerLanes> value;
      std::array<double, kSamplerLanes> rel_var{};
      for (int k = 0; k < lanes; ++k) n[k] = normal(first + k);
      sampler.eval(n.data(), lanes, value.data(), with_rel_var ? rel_var.data() : nullptr);
      for (int k = 0; k < lanes; ++k) store(first + k, value[k], rel_var[k]);
    }
  });
}

// Brute force over every texel of one cube at a few normals (the reference of the checked subset). Each texel's
// direction, solid angle and radiance are gathered once, in the order the sums visit them.
class BruteForce {
 public:
  BruteForce(const Cubemap& src, const SplitSumLobe& lobe) : src_(src), lobe_(lobe) {
    const int m = src.size();
    const std::vector<double>& omega = *texel_solid_angles(m);
    texels_.reserve(static_cast<size_t>(kFaceCount) * m * m);
    for (int f = 0; f < kFaceCount; ++f)
      for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x)
          texels_.push_back({texel_direction(f, x, y, m), omega[static_cast<size_t>(y) * m + x], src.at(f, x, y)});
  }
  // The convolutions at n[0 .. count), count ≤ kGroup, into out: each texel is read once for all of them (the
  // source's texels outgrow the caches, and reading them once per normal made the sums memory-bound), while each
  // normal's sum still visits the texels in order, so every value is the one a sum per normal gives.
  static constexpr int kGroup = 8;
  void at(const Vec3* n, int count, Rgb* out) const {
    std::array<Rgb, kGroup> sum{};
    std::array<double, kGroup> w{};
    for (const Texel& t : texels_) {
      for (int k = 0; k < count; ++k) {
        const double wt = lobe_.weight(n[k], t.l) * t.omega;
        if (wt == 0.0) continue;
        sum[k] += t.radiance * wt;
        w[k] += wt;
      }
    }
    // w = 0: no texel centre lies inside the lobe's support (Schlick's compact D narrower than the texels of a
    // coarse source); the convolution of so narrow a lobe is the reconstructed radiance at n.
    for (int k = 0; k < count; ++k) out[k] = w[k] > 0.0 ? sum[k] / w[k] : src_.sample_bilinear(n[k]);
  }

 private:
  struct Texel {
    Vec3 l;
    double omega;
    Rgb radiance;
  };
  const Cubemap& src_;
  const SplitSumLobe& lobe_;
  std::vector<Texel> texels_;
};

double rgb_norm2(const Rgb& c) { return c.r * c.r + c.g * c.g + c.b * c.b; }

struct Checked {
  int face, x, y;
  Vec3 n;
  Rgb reference;
};

// The stratified subset of texels that is checked against brute force.
std::vector<Checked> checked_subset(int size) {
  std::vector<Checked> out;
  const int grid = size <= 8 ? size : 4;
  for (int f = 0; f < kFaceCount; ++f)
    for (int j = 0; j < grid; ++j)
      for (int i = 0; i < grid; ++i) {
        const int x = size <= 8 ? i : static_cast<int>((i + 0.5) * size / grid);
        const int y = size <= 8 ? j : static_cast<int>((j + 0.5) * size / grid);
        out.push_back({f, x, y, texel_direction(f, x, y, size), Rgb{}});
      }
  return out;
}

// The relative RMS error (relative_rms_error in the header) over (value, reference) pairs.
double relative_rms_pairs(size_t n, const std::function<Rgb(size_t)>& value, const std::function<Rgb(size_t)>& ref) {
  if (n == 0) return 0.0;
  double mean_sq = 0.0;
  for (size_t i = 0; i < n; ++i) mean_sq += rgb_norm2(ref(i)) / n;
  const double floor_sq = kRelativeErrorFloor * kRelativeErrorFloor * mean_sq;
  // An all-black reference has no relative error (and the estimate there is black too).
  if (floor_sq == 0.0) return 0.0;
  double acc = 0.0;
  for (size_t i = 0; i < n; ++i) acc += rgb_norm2(value(i) - ref(i)) / std::max(rgb_norm2(ref(i)), floor_sq);
  return std::sqrt(acc / n);
}

double relative_rms(const std::vector<Checked>& subset, const std::vector<Rgb>& values) {
  return relative_rms_pairs(
      subset.size(), [&](size_t i) { return values[i]; }, [&](size_t i) { return subset[i].reference; });
}

int round_samples(double n) {
  const double clamped = std::clamp(std::ceil(n), 1.0, static_cast<double>(kMaxSamples));
  return std::min(kMaxSamples, (static_cast<int>(clamped) + kSamplerGroups - 1) / kSamplerGroups * kSamplerGroups);
}

// The lobe of one level: its width α, its weight D(h)(n·l) and that weight's integral W.
struct LevelLobe {
  double alpha;
  SplitSumLobe lobe;
  double w_norm;
};

// The checked subset of a level of size out_size, each with its reference: brute force over the sky mip of size
// ≥ min(size0, 16/α), plus the sun.
std::vector<Checked> checked_reference(const std::vector<Cubemap>& mips, const std::vector<SunTexel>& sun,
                                       const LevelLobe& l, int out_size) {
  std::vector<Checked> subset = checked_subset(out_size);
  const double wanted = std::min<double>(mips[0].size(), std::ceil(kReferenceTexelsPerAlpha / l.alpha));
  size_t m = 0;
  while (m + 1 < mips.size() && mips[m + 1].size() >= wanted) ++m;
  const BruteForce reference(mips[m], l.lobe);
  const int groups = static_cast<int>((subset.size() + BruteForce::kGroup - 1) / BruteForce::kGroup);
  tbb::parallel_for(0, groups, [&](int g) {
    const size_t first = static_cast<size_t>(g) * BruteForce::kGroup;
    const int count = static_cast<int>(std::min<size_t>(BruteForce::kGroup, subset.size() - first));
    std::array<Vec3, BruteForce::kGroup> n;
    std::array<Rgb, BruteForce::kGroup> convolved;
    for (int k = 0; k < count; ++k) n[k] = subset[first + k].n;
    reference.at(n.data(), count, convolved.data());
    for (int k = 0; k < count; ++k) {
      subset[first + k].reference = convolved[k] + sun_specular_at(sun, l.lobe, l.w_norm, n[k]);
    }
  });
  return subset;
}

// N per texel: the job's, else chosen from the target error by `check`, which measures the checked error of N.
// From kPilotSamples, N is scaled by (e/target)² × kStepMargin (the 1/√N law of noise, which overestimates N since
// the bias of filtered importance sampling and the QMC noise fall faster) until the target is bracketed between a
// failing and a passing N, which are then bisected geometrically (within 50 %), at most kMaxTrials trials; the
// smallest N that met the target is kept, else the last (capped) one.
int choose_samples(const PrefilterOptions& opt, const std::function<double(int)>& check) {
  if (opt.samples != 0) return round_samples(opt.samples);
  int n = kPilotSamples, passed = 0, failed = 0;
  for (int trial = 0; trial < kMaxTrials; ++trial) {
    if (opt.cancel && opt.cancel->load()) break;
    const double e = check(n);
    const double step = (e / opt.target_error) * (e / opt.target_error) * kStepMargin;
    if (e <= opt.target_error)
      passed = n;
    else
      failed = n;
    int next;
    if (passed && failed) {
      if (passed < failed * 3 / 2) break;  // bracketed within 50 %: good enough
      next = round_samples(std::sqrt(double(passed) * failed));
    } else if (passed) {
      if (n <= kMinAutoSamples) break;
      next = std::max(kMinAutoSamples, round_samples(n * step));
      if (next >= n * 3 / 4) break;  // not worth another trial
    } else {
      if (n >= kMaxSamples) break;
      next = std::min(kMaxSamples, std::max(round_samples(n * step), n + kSamplerGroups));
    }
    if (next == n || next == passed || next == failed) break;
    n = next;
  }
  return passed ? passed : n;
}

// Every texel of the level with N = level.samples, plus the exact sun; sets the cube and the noise estimate.
void sample_level(PrefilteredLevel& level, const PaddedMips& padded, int size0, const std::vector<SunTexel>& sun,
                  const LevelLobe& l, int out_size, const PrefilterOptions& opt, uint64_t level_seed) {
  const LevelSampler sampler(padded, size0, l.alpha, opt.distribution, level.samples, level_seed, opt.lod_bias);
  level.cube = Cubemap(out_size);
  const int per_face = out_size * out_size;
  std::vector<double> rel_var(static_cast<size_t>(kFaceCount) * per_face, 0.0);
  eval_in_lanes(
      sampler, kFaceCount * per_face,
      [&](int idx) {
        return texel_direction(idx / per_face, idx % per_face % out_size, idx % per_face / out_size, out_size);
      },
      [&](int idx, const Rgb& value, double r) {
        level.cube.at(idx / per_face, idx % per_face % out_size, idx % per_face / out_size) = value;
        rel_var[idx] = r;
      },
      true, opt.cancel);
  add_sun_specular(level.cube, sun, l.lobe, l.w_norm);
  double acc = 0.0;
  for (double r : rel_var) acc += r;
  level.noise_estimate = std::sqrt(acc / rel_var.size());
}

PrefilteredLevel prefilter_level(const std::vector<Cubemap>& mips, const PaddedMips& padded,
                                 const std::vector<SunTexel>& sun, int out_size, double rho,
                                 const PrefilterOptions& opt, uint64_t level_seed) {
  const auto t0 = std::chrono::steady_clock::now();
  PrefilteredLevel level;
  level.roughness = rho;
  const double alpha = lobe_alpha(rho);
  const LevelLobe l{alpha, SplitSumLobe(opt.distribution, alpha), lobe_normalization(opt.distribution, alpha)};

  const std::vector<Checked> subset = checked_reference(mips, sun, l, out_size);
  level.checked_texels = static_cast<int>(subset.size());
  std::vector<Rgb> sun_at_subset(subset.size());
  for (size_t i = 0; i < subset.size(); ++i) sun_at_subset[i] = sun_specular_at(sun, l.lobe, l.w_norm, subset[i].n);
  const auto check = [&](int samples) {
    const LevelSampler sampler(padded, mips[0].size(), alpha, opt.distribution, samples, level_seed, opt.lod_bias);
    std::vector<Rgb> values(subset.size());
    eval_in_lanes(
        sampler, static_cast<int>(subset.size()), [&](int i) { return subset[i].n; },
        [&](int i, const Rgb& value, double) { values[i] = value + sun_at_subset[i]; }, false, opt.cancel);
    level.pilot_samples += samples;
    return relative_rms(subset, values);
  };
  level.samples = choose_samples(opt, check);

  sample_level(level, padded, mips[0].size(), sun, l, out_size, opt, level_seed);
  std::vector<Rgb> values(subset.size());
  for (size_t i = 0; i < subset.size(); ++i) values[i] = level.cube.at(subset[i].face, subset[i].x, subset[i].y);
  level.checked_error = relative_rms(subset, values);
  level.error_estimate = std::max(level.checked_error, level.noise_estimate);
  level.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return level;
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

std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& sky, const std::vector<SunTexel>& sun, int out_size,
                                                 const PrefilterOptions& opt) {
  if (sky.size() < 1) throw std::invalid_argument("prefilter_specular: empty source");
  if (out_size < 1)
    throw std::invalid_argument("prefilter_specular: out_size must be >= 1, got " + std::to_string(out_size));
  if (opt.levels < 1)
    throw std::invalid_argument("prefilter_specular: levels must be >= 1, got " + std::to_string(opt.levels));
  if (opt.samples < 0 || opt.samples > kMaxSamples)
    throw std::invalid_argument("prefilter_specular: samples must be in [0, 65536], got " +
                                std::to_string(opt.samples));
  if (!(opt.target_error > 0.0 && opt.target_error <= 1.0))
    throw std::invalid_argument("prefilter_specular: target_error must be in (0, 1]");
  if (!(opt.lod_bias >= -4.0 && opt.lod_bias <= 4.0))
    throw std::invalid_argument("prefilter_specular: lod_bias must be in [-4, 4]");
  const std::vector<Cubemap> mips = build_source_mips(sky);
  const PaddedMips padded(mips);
  std::vector<PrefilteredLevel> chain;
  for (int k = 0; k < opt.levels; ++k) {
    if (opt.cancel && opt.cancel->load()) break;  // the caller discards the incomplete chain
    const double rho = prefilter_level_roughness(k, opt.levels);
    const int size = std::max(1, out_size >> k);
    if (k == 0 || rho <= 0.0) {
      // Mirror (D a delta): the sky's own mip of that size if there is one (area-correct), else bilinear
      // resampling; the sun's power deposited back into the texels that contain it.
      const auto t0 = std::chrono::steady_clock::now();
      PrefilteredLevel level;
      level.roughness = rho;
      const auto it = std::find_if(mips.begin(), mips.end(), [&](const Cubemap& c) { return c.size() == size; });
      if (it != mips.end()) {
        level.cube = *it;
      } else {
        level.cube = Cubemap(size);
        for_each_texel(size, [&](int f, int x, int y, int) {
          level.cube.at(f, x, y) = mips[0].sample_bilinear(texel_direction(f, x, y, size));
        });
      }
      deposit_sun(level.cube, sun);
      level.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      chain.push_back(std::move(level));
      continue;
    }
    chain.push_back(prefilter_level(mips, padded, sun, size, rho, opt, opt.seed + 0x9e3779b97f4a7c15ULL * (k + 1)));
  }
  return chain;
}

std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& source, int out_size, const PrefilterOptions& opt) {
  return prefilter_specular(source, {}, out_size, opt);
}

double relative_rms_error(const Cubemap& value, const Cubemap& reference) {
  if (value.size() != reference.size()) throw std::invalid_argument("relative_rms_error: the cubes differ in size");
  const size_t per_face = static_cast<size_t>(value.size()) * value.size();
  return relative_rms_pairs(
      kFaceCount * per_face, [&](size_t i) { return value.face(int(i / per_face))[i % per_face]; },
      [&](size_t i) { return reference.face(int(i / per_face))[i % per_face]; });
}

Cubemap brute_force_prefilter(const Cubemap& src, int out_size, double roughness, int subdivisions) {
  return brute_force_prefilter(src, out_size, roughness, brdf::Distribution::ggx, subdivisions);
}

Cubemap brute_force_prefilter(const Cubemap& src, int out_size, double roughness, brdf::Distribution distribution,
                              int subdivisions) {
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
  const SplitSumLobe lobe(distribution, lobe_alpha(roughness));
  const int ns = src.size(), k = subdivisions;
  // Every (sub-)texel's direction, solid angle and radiance, once.
  struct Texel {
    Vec3 l;
    double omega;
    Rgb radiance;
  };
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
            const Vec3 l =
                normalize(face_uv_to_direction(f, (a0 + 0.5 * step + 1.0) / 2.0, (b0 + 0.5 * step + 1.0) / 2.0));
            texels.push_back({l, face_rect_solid_angle(a0, b0, a0 + step, b0 + step), src.sample_bilinear(l)});
          }
      }
  for_each_texel(out_size, [&](int f, int x, int y, int) {
    const Vec3 n = texel_direction(f, x, y, out_size);
    Rgb sum;
    double w = 0.0;
    for (const Texel& t : texels) {
      const double weight = lobe.weight(n, t.l) * t.omega;  // 0 below the horizon of n
      if (weight == 0.0) continue;
      sum += t.radiance * weight;
      w += weight;
    }
    // w = 0: no (sub-)texel centre inside the lobe's support (Schlick's compact D narrower than the texels); the
    // convolution of so narrow a lobe is the reconstructed radiance at n.
    out.at(f, x, y) = w > 0.0 ? sum / w : src.sample_bilinear(n);
  });
  return out;
}

}  // namespace kiln::envmap
