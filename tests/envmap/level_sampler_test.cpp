// The prefilter's sampler evaluates kSamplerLanes texels at once with a branch-free, vectorised face lookup and floor.
// Its values must be those of the plain scalar reads it replaces, bit for bit: each sample read with
// Cubemap::sample_bilinear (std::floor, Cubemap::texel_extended across edges) on the two mips around its level, and
// the sums taken in sample order. Tolerance: none (EXPECT_EQ), since every step is the same IEEE arithmetic.
#include "bakers/envmap/level_sampler.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "bakers/envmap/prefilter.h"
#include "bakers/math/rgb.h"
#include "bakers/math/rng.h"

namespace kiln::envmap {
namespace {

// A 16² cube with structure at the texel scale and a channel spanning four decades (so that a + (b − a)·1 is not b
// exactly), so that any misplaced tap or weight changes the value.
Cubemap structured_cube() {
  Cubemap c(16);
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) {
        const Vec3 d = texel_direction(f, x, y, 16);
        c.at(f, x, y) = {1.0 + std::sin(7.0 * d.x + 3.0 * d.y), 1.5 + std::cos(5.0 * d.z) * d.y,
                         std::exp(0.5 * f - 1.0 + 0.3 * ((x * 7 + y * 3) % 11))};
      }
  return c;
}

// Unit normals: the axes, the face edges and corners (ties between the major axes), and random directions.
std::vector<Vec3> test_normals() {
  std::vector<Vec3> n;
  for (int axis = 0; axis < 3; ++axis)
    for (double s : {1.0, -1.0}) {
      Vec3 v;
      (axis == 0 ? v.x : axis == 1 ? v.y : v.z) = s;
      n.push_back(v);
    }
  n.push_back(normalize(Vec3{1, 1, 0}));
  n.push_back(normalize(Vec3{-1, 0, 1}));
  n.push_back(normalize(Vec3{0, -1, -1}));
  n.push_back(normalize(Vec3{1, 1, 1}));
  n.push_back(normalize(Vec3{-1, 1, -1}));
  Pcg32 rng(7, 11);
  while (n.size() < 43) {
    const Vec3 v{2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 2 * rng.uniform() - 1};
    if (dot(v, v) > 1e-3 && dot(v, v) <= 1.0) n.push_back(normalize(v));
  }
  return n;
}

// The estimate at n the plain way: every sample's direction through Frame::from_local, read with
// Cubemap::sample_bilinear on its two mips and blended with lerp; group sums in sample order.
Rgb scalar_estimate(const LevelSampler& sampler, const std::vector<Cubemap>& mips, const Vec3& n) {
  const Frame frame = Frame::from_normal(n);
  Rgb sum_all;
  double w_all = 0.0;
  for (int g = 0; g < kSamplerGroups; ++g) {
    const LevelSampler::Group& group = sampler.group(g);
    Rgb sum;
    for (size_t i = 0; i < group.lz.size(); ++i) {
      const Vec3 d = frame.from_local({group.lx[i], group.ly[i], group.lz[i]});
      Rgb c = mips[group.l0[i]].sample_bilinear(d);
      if (group.t[i] != 0.0) c = lerp(group.t[i], c, mips[group.l0[i] + 1].sample_bilinear(d));
      sum += c * group.lz[i];
    }
    sum_all += sum;
    w_all += group.w;
  }
  return sum_all / w_all;
}

TEST(LevelSampler, EqualsScalarReadsBitForBit) {
  const std::vector<Cubemap> mips = build_source_mips(structured_cube());
  const PaddedMips padded(mips);
  const std::vector<Vec3> normals = test_normals();
  for (double alpha : {0.02, 0.3, 1.0}) {
    const LevelSampler sampler(padded, 16, alpha, brdf::Distribution::ggx, 64, 3, kDefaultLodBias);
    int with_two_levels = 0;
    for (int g = 0; g < kSamplerGroups; ++g)
      for (double t : sampler.group(g).t) with_two_levels += t != 0.0;
    EXPECT_GT(with_two_levels, 0) << "alpha " << alpha << ": no trilinear read is exercised";
    for (size_t first = 0; first < normals.size(); first += kSamplerLanes) {
      const int count = static_cast<int>(std::min<size_t>(kSamplerLanes, normals.size() - first));
      std::array<Rgb, kSamplerLanes> value;
      sampler.eval(&normals[first], count, value.data(), nullptr);
      for (int k = 0; k < count; ++k)
        EXPECT_EQ(value[k], scalar_estimate(sampler, mips, normals[first + k]))
            << "alpha " << alpha << ", normal " << first + k;
    }
  }
}

// The measure-zero cases that random samples never meet: directions exactly on face edges and corners (ties between
// the major axes, broken as direction_to_face_uv breaks them) and reads at exact texel centres (p = u·size − ½ an
// integer, where floor and truncation must agree). With every sample at l = +z, each direction is the normal itself.
TEST(LevelSampler, EqualsScalarReadsOnEdgesCornersAndTexelCentres) {
  const std::vector<Cubemap> mips = build_source_mips(structured_cube());  // 16², 8², 4², 2², 1²
  const PaddedMips padded(mips);
  std::array<LevelSampler::Group, kSamplerGroups> groups;
  for (int g = 0; g < kSamplerGroups; ++g) {
    // Level 4 (1²) alone, levels 3 and 4 blended, level 0 alone: on an axis, p = 0 at 1² (an integer).
    groups[g].lx = {0.0, 0.0, 0.0};
    groups[g].ly = {0.0, 0.0, 0.0};
    groups[g].lz = {1.0, 0.5, 0.25};
    groups[g].l0 = {4, 3, g};
    groups[g].t = {0.0, 0.25 * (g + 1), 0.0};
  }
  const LevelSampler sampler(padded, groups);
  std::vector<Vec3> normals;
  for (double a : {1.0, -1.0}) {
    normals.push_back({a, 0, 0}), normals.push_back({0, a, 0}), normals.push_back({0, 0, a});
    for (double b : {1.0, -1.0}) {
      normals.push_back(normalize(Vec3{a, b, 0})), normals.push_back(normalize(Vec3{a, 0, b}));
      normals.push_back(normalize(Vec3{0, a, b}));
      for (double c : {1.0, -1.0}) normals.push_back(normalize(Vec3{a, b, c}));
    }
  }
  for (size_t first = 0; first < normals.size(); first += kSamplerLanes) {
    const int count = static_cast<int>(std::min<size_t>(kSamplerLanes, normals.size() - first));
    std::array<Rgb, kSamplerLanes> value;
    sampler.eval(&normals[first], count, value.data(), nullptr);
    for (int k = 0; k < count; ++k)
      EXPECT_EQ(value[k], scalar_estimate(sampler, mips, normals[first + k])) << "normal " << first + k;
  }
}

TEST(LevelSampler, LanesDoNotChangeValues) {
  const std::vector<Cubemap> mips = build_source_mips(structured_cube());
  const PaddedMips padded(mips);
  const std::vector<Vec3> normals = test_normals();
  const LevelSampler sampler(padded, 16, 0.2, brdf::Distribution::beckmann, 48, 5, 0.5);
  std::array<Rgb, kSamplerLanes> together;
  std::array<double, kSamplerLanes> rel_var_together;
  sampler.eval(normals.data(), kSamplerLanes, together.data(), rel_var_together.data());
  for (int k = 0; k < kSamplerLanes; ++k) {
    Rgb alone;
    double rel_var_alone = -1.0;
    sampler.eval(&normals[k], 1, &alone, &rel_var_alone);
    EXPECT_EQ(together[k], alone) << "normal " << k;
    EXPECT_EQ(rel_var_together[k], rel_var_alone) << "normal " << k;
  }
}

}  // namespace
}  // namespace kiln::envmap
