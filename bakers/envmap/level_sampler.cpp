#include "bakers/envmap/level_sampler.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"

namespace kiln::envmap {
namespace {

constexpr int K = kSamplerLanes;

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

// A fractional mip level, clamped to the chain, as the level below and the weight of the one above (t = 0: that
// level alone).
void split_lod(double lod, int levels, int& l0, double& t) {
  lod = std::clamp(lod, 0.0, static_cast<double>(levels - 1));
  l0 = static_cast<int>(std::floor(lod));
  t = lod - l0;
  if (l0 + 1 >= levels) t = 0.0;
}

// Where one sample falls in one mip level, per lane: the offset of the top-left of the four bilinear taps in the
// level's padded texels (an integer, held in a double so that the loop computing it has one element type), and the
// bilinear weights.
struct LaneTaps {
  double offset[K], wx[K], wy[K];
};

// The lanes' local frames (Frame::from_normal of each lane's normal).
struct LaneFrames {
  double sx[K], sy[K], sz[K], tx[K], ty[K], tz[K], nx[K], ny[K], nz[K];
};

// Lane k's taps in `level` at face coordinates (u, v): Cubemap::sample_bilinear's p = u·size − ½ and its floor,
// taken without a branch or a call (x86-64's baseline SSE2 has no vector floor): r = (p + 1.5·2^52) − 1.5·2^52 is
// p rounded to the nearest integer, exactly, for |p| < 2^51, and floor(p) is r, or r − 1 when r > p. Every value is
// an integer or p − floor(p), both exact, so the weights are std::floor's bit for bit.
inline void locate_taps(const PaddedMips::Level& level, double face, double u, double v, LaneTaps& taps, int k) {
  constexpr double kRound = 6755399441055744.0;  // 1.5·2^52
  const double px = u * level.size - 0.5, py = v * level.size - 0.5;
  const double rx = (px + kRound) - kRound, ry = (py + kRound) - kRound;
  // (r + 1) − 2 rather than r − 1: a select between r and r − 1 would put the subtraction in a branch.
  const double fx = (rx + 1.0) - (rx > px ? 2.0 : 1.0), fy = (ry + 1.0) - (ry > py ? 2.0 : 1.0);
  taps.wx[k] = px - fx;
  taps.wy[k] = py - fy;
  // px, py ∈ [−½, size − ½]: the taps lie in [−1, size], inside the border.
  taps.offset[k] = face * level.face_stride + (fy + 1.0) * level.stride + (fx + 1.0);
}

// Sample l (local frame) for every lane: its direction d, direction_to_face_uv(d) (the same comparisons and
// arithmetic, as two-way selects of values already computed) and its taps in the levels below and above. The loop
// has no branch, no call and one element type, and its arrays do not alias, so GCC vectorises it at -O2 (check with
// -fopt-info-vec: "loop vectorized"); keep it so (GCC's jump threading turns some orders of these selects back
// into branches).
void locate(const LaneFrames& __restrict fr, double lx, double ly, double lz, const PaddedMips::Level& below,
            const PaddedMips::Level& above, LaneTaps& __restrict taps_below, LaneTaps& __restrict taps_above) {
  for (int k = 0; k < K; ++k) {
    // Frame::from_local: s l.x + t l.y + n l.z.
    const double dx = fr.sx[k] * lx + fr.tx[k] * ly + fr.nx[k] * lz;
    const double dy = fr.sy[k] * lx + fr.ty[k] * ly + fr.ny[k] * lz;
    const double dz = fr.sz[k] * lx + fr.tz[k] * ly + fr.nz[k] * lz;
    const double ax = std::fabs(dx), ay = std::fabs(dy), az = std::fabs(dz);
    const bool pos_x = dx >= 0, pos_y = dy >= 0, pos_z = dz >= 0;
    const bool major_x = (ax >= ay) & (ax >= az), major_y = !major_x & (ay >= az);
    // (sc, tc, ma) of the OpenGL table: +X (−z, −y), −X (z, −y), +Y (x, z), −Y (x, −z), +Z (x, −y), −Z (−x, −y).
    const double sc_z = pos_z ? dx : -dx, sc_x = pos_x ? -dz : dz;
    const double sc_yz = major_y ? dx : sc_z;
    const double sc = major_x ? sc_x : sc_yz;
    const double tc_y = pos_y ? dz : -dz;
    const double tc = major_y ? tc_y : -dy;
    const double ma_yz = major_y ? ay : az;
    const double ma = major_x ? ax : ma_yz;
    // The zero vector (ma = 0) reads as the centre of +X, as in direction_to_face_uv: sc = tc = 0 then, and the
    // floor on ma keeps 0/0 away (d is a unit vector here, so the case does not arise).
    const double ma_safe = std::max(ma, std::numeric_limits<double>::min());
    const double face_x = pos_x ? 0.0 : 1.0, face_y = pos_y ? 2.0 : 3.0, face_z = pos_z ? 4.0 : 5.0;
    const double face_yz = major_y ? face_y : face_z;
    const double face = major_x ? face_x : face_yz;
    const double u = 0.5 * (sc / ma_safe + 1.0), v = 0.5 * (tc / ma_safe + 1.0);
    locate_taps(below, face, u, v, taps_below, k);
    locate_taps(above, face, u, v, taps_above, k);
  }
}

// a + t (b − a): Cubemap::sample_bilinear's lerp, exact when a == b.
inline Rgb lerp_exact(double t, const Rgb& a, const Rgb& b) { return a + (b - a) * t; }

inline Rgb bilinear(const PaddedMips::Level& level, const LaneTaps& taps, int k) {
  const Rgb* row = level.texels.data() + static_cast<ptrdiff_t>(taps.offset[k]);
  const Rgb top = lerp_exact(taps.wx[k], row[0], row[1]);
  const Rgb bottom = lerp_exact(taps.wx[k], row[level.stride], row[level.stride + 1]);
  return lerp_exact(taps.wy[k], top, bottom);
}

// The lanes' frames from their normals; lanes beyond count repeat the last normal (their results are not returned).
LaneFrames lane_frames(const Vec3* n, int count) {
  LaneFrames fr;
  for (int k = 0; k < K; ++k) {
    const Frame f = Frame::from_normal(n[std::min(k, count - 1)]);
    fr.sx[k] = f.s.x, fr.sy[k] = f.s.y, fr.sz[k] = f.s.z;
    fr.tx[k] = f.t.x, fr.ty[k] = f.t.y, fr.tz[k] = f.t.z;
    fr.nx[k] = f.n.x, fr.ny[k] = f.n.y, fr.nz[k] = f.n.z;
  }
  return fr;
}

// The lanes' Σ L(l_i)(n·l_i) over one group.
struct LaneSums {
  double r[K] = {}, g[K] = {}, b[K] = {};
};

// Σ L(l_i)(n·l_i) over one group's samples for every lane: per sample, locate (vectorised), then the reads, in
// sample order per lane.
void accumulate(const PaddedMips& mips, const LevelSampler::Group& group, const LaneFrames& fr, LaneSums& sums) {
  for (size_t i = 0; i < group.lz.size(); ++i) {
    const double t = group.t[i], nl = group.lz[i];
    const PaddedMips::Level& below = mips.level(group.l0[i]);
    const PaddedMips::Level& above = mips.level(t == 0.0 ? group.l0[i] : group.l0[i] + 1);
    LaneTaps taps_below, taps_above;
    locate(fr, group.lx[i], group.ly[i], group.lz[i], below, above, taps_below, taps_above);
    for (int k = 0; k < K; ++k) {
      Rgb c = bilinear(below, taps_below, k);
      if (t != 0.0) c = lerp(t, c, bilinear(above, taps_above, k));
      sums.r[k] += c.r * nl;
      sums.g[k] += c.g * nl;
      sums.b[k] += c.b * nl;
    }
  }
}

}  // namespace

PaddedMips::PaddedMips(const std::vector<Cubemap>& mips) : levels_(mips.size()) {
  for (size_t m = 0; m < mips.size(); ++m) {
    const Cubemap& c = mips[m];
    Level& l = levels_[m];
    l.size = c.size();
    l.stride = l.size + 2;
    l.face_stride = l.stride * l.stride;
    l.texels.resize(static_cast<size_t>(kFaceCount) * l.face_stride);
    for (int f = 0; f < kFaceCount; ++f)
      for (int y = -1; y <= l.size; ++y)
        for (int x = -1; x <= l.size; ++x)
          l.texels[static_cast<size_t>(f) * l.face_stride + static_cast<size_t>(y + 1) * l.stride + (x + 1)] =
              c.texel_extended(f, x, y);
  }
}

LevelSampler::LevelSampler(const PaddedMips& mips, int size0, double alpha, brdf::Distribution distribution,
                           int samples, uint64_t seed, double lod_bias)
    : mips_(mips) {
  const int per_group = (samples + kSamplerGroups - 1) / kSamplerGroups;
  const int n_total = per_group * kSamplerGroups;
  const brdf::MicrofacetDistribution dist(distribution, alpha, alpha);
  const double omega_p = 4.0 * kPi / (6.0 * size0 * size0);  // solid angle of one level-0 source texel (average)
  Pcg32 rng(0x9e3779b97f4a7c15ULL ^ seed, 0x6a09e667f3bcc909ULL);
  const Vec3 v{0, 0, 1};
  for (Group& group : groups_) {
    const Point2 shift{rng.uniform(), rng.uniform()};
    for (int i = 0; i < per_group; ++i) {
      const Vec3 h = dist.sample_wh(v, hammersley(i, per_group, shift));
      const double vh = dot(v, h);
      const Vec3 l = h * (2.0 * vh) - v;
      // Below the horizon (n·l ≤ 0) the weight is zero; vh ≤ 0 would make p(l) singular — neither contributes.
      if (l.z <= 0.0 || vh <= 0.0) continue;
      const double pdf_l = dist.pdf_wh(v, h) / (4.0 * vh);
      // A zero density (numerically, far in the tail) would give an infinite Ω_s: read the coarsest level.
      const double lod = pdf_l > 0.0 ? 0.5 * std::log2(1.0 / (n_total * pdf_l) / omega_p) + lod_bias : 1e9;
      int l0;
      double t;
      split_lod(lod, mips.count(), l0, t);
      group.lx.push_back(l.x), group.ly.push_back(l.y), group.lz.push_back(l.z);
      group.l0.push_back(l0), group.t.push_back(t);
      group.w += l.z;
    }
  }
}

LevelSampler::LevelSampler(const PaddedMips& mips, const std::array<Group, kSamplerGroups>& groups)
    : mips_(mips), groups_(groups) {
  for (Group& group : groups_) {
    group.w = 0.0;
    for (double nl : group.lz) group.w += nl;
  }
}

void LevelSampler::eval(const Vec3* n, int count, Rgb* value, double* rel_var) const {
  const LaneFrames fr = lane_frames(n, count);
  std::array<LaneSums, kSamplerGroups> sums;
  for (int g = 0; g < kSamplerGroups; ++g) accumulate(mips_, groups_[g], fr, sums[g]);
  for (int k = 0; k < count; ++k) {
    std::array<Rgb, kSamplerGroups> group_sum;
    for (int g = 0; g < kSamplerGroups; ++g) group_sum[g] = {sums[g].r[k], sums[g].g[k], sums[g].b[k]};
    value[k] = combine_groups(group_sum, rel_var ? &rel_var[k] : nullptr);
  }
}

Rgb LevelSampler::combine_groups(const std::array<Rgb, kSamplerGroups>& group_sum, double* rel_var) const {
  Rgb sum_all;
  double w_all = 0.0;
  std::array<double, kSamplerGroups> group_mean{};
  for (int g = 0; g < kSamplerGroups; ++g) {
    const double w = groups_[g].w;
    sum_all += group_sum[g];
    w_all += w;
    // A group with no sample above the horizon (cannot happen for N/4 ≥ 1, guarded anyway) reads 0.
    group_mean[g] = w > 0.0 ? (group_sum[g] / w).average() : 0.0;
  }
  const Rgb value = w_all > 0.0 ? sum_all / w_all : Rgb{};
  if (!rel_var) return value;
  double mean = 0.0;
  for (double m : group_mean) mean += m / kSamplerGroups;
  double var = 0.0;
  for (double m : group_mean) var += (m - mean) * (m - mean) / (kSamplerGroups - 1);
  const double denom = std::abs(value.average());
  // A zero (black) texel has no relative error.
  *rel_var = denom > 0.0 ? var / kSamplerGroups / (denom * denom) : 0.0;
  return value;
}

}  // namespace kiln::envmap
