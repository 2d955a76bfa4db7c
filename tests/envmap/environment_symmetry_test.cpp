// Symmetries of the whole environment bake, on a small generated environment with no symmetry of its own:
//   rotation  — turning the input 90° about +Y moves the output faces as the conventions say, at every level of the
//               specular chain and in the irradiance cube;
//   edges     — the two texels on either side of every cube edge agree as closely as neighbouring texels inside a
//               face do, at every level;
//   container — specular.ktx2 of a real bake holds every level and face of the EXR faces, to half precision, with
//               its key/value metadata.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/env_input.h"
#include "bakers/envmap/environment_bake.h"
#include "bakers/envmap/irradiance.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/image/exr.h"
#include "bakers/image/half.h"
#include "bakers/image/ktx2.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

// The test environment, 64 × 32 (W divisible by 4: a 90° turn is a shift by exactly 16 columns), in the equirect
// convention of cubemap.h. Smooth variation in all three channels with different azimuthal orders (no rotational
// or mirror symmetry about +Y), a sky gradient, and a bright, soft spot at longitude 40°, elevation 20°.
std::string test_environment_exr() {
  constexpr int kW = 64, kH = 32;
  image::FloatImage img;
  img.width = kW;
  img.height = kH;
  img.channels = 3;
  img.channel_names = {"R", "G", "B"};
  const Vec3 spot =
      normalize(Vec3{std::sin(40.0 * kPi / 180), std::tan(20.0 * kPi / 180), -std::cos(40.0 * kPi / 180)});
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const double u = (x + 0.5) / kW, v = (y + 0.5) / kH;
      const double phi = 2.0 * kPi * (u - 0.5), theta = kPi * v;
      const Vec3 d = equirect_uv_to_direction(u, v);
      const double blob = 6.0 * std::exp(-40.0 * (1.0 - dot(d, spot)));
      img.pixels.push_back(static_cast<float>(0.6 + 0.4 * std::sin(phi + 0.7) * std::sin(theta) + blob));
      img.pixels.push_back(static_cast<float>(0.5 + 0.3 * std::cos(2.0 * phi - 0.4) * std::sin(theta) +
                                              0.2 * std::cos(theta) + 0.5 * blob));
      img.pixels.push_back(static_cast<float>(0.7 + 0.25 * std::sin(3.0 * phi + 1.1) * std::sin(theta) +
                                              0.3 * std::cos(theta) + 0.2 * blob));
    }
  }
  // A sun: 2 × 2 pixels at longitude ≈ −96°, elevation ≈ 37°, thousands of times the sky, so that the bake's sky/sun
  // split (sun.h) is part of what is checked.
  for (int y : {9, 10})
    for (int x : {14, 15})
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = 3000.0f - 200.0f * c;
  return image::encode_exr(img);
}

// ---- rotation ----------------------------------------------------------------------------------------------------
//
// With α = 90° (env_input.h) the output's radiance towards d is the input's towards R_y(−90°) d = (−d.z, d.y, d.x).
// Writing each face's texel direction with a = 2s − 1, b = 2t − 1 (cubemap.h) and applying that map:
//   +X: ( 1, −b, −a) → ( a, −b,  1) = +Z at (a, b)        −X: (−1, −b,  a) → (−a, −b, −1) = −Z at (a, b)
//   +Z: ( a, −b,  1) → (−1, −b,  a) = −X at (a, b)        −Z: (−a, −b, −1) → ( 1, −b, −a) = +X at (a, b)
//   +Y: ( a,  1,  b) → (−b,  1,  a) = +Y at (a', b') = (−b, a)
//   −Y: ( a, −1, −b) → ( b, −1,  a) = −Y at (a', b') = (b, −a)
// so rotated(face, x, y) = original(source face, x', y'): the side faces permute with their texels in place, the ±Y
// faces turn in their plane (a' = −b: x' = N − 1 − y; b' = a: y' = x; and the reverse for −Y).
struct TexelRef {
  int face, x, y;
};
TexelRef rotated_source(int face, int x, int y, int n) {
  switch (face) {
    case 0:
      return {4, x, y};
    case 1:
      return {5, x, y};
    case 2:
      return {2, n - 1 - y, x};
    case 3:
      return {3, y, n - 1 - x};
    case 4:
      return {1, x, y};
    case 5:
      return {0, x, y};
  }
  return {face, x, y};
}

double max_abs_diff(const Rgb& a, const Rgb& b) {
  return std::max({std::abs(a.r - b.r), std::abs(a.g - b.g), std::abs(a.b - b.b)});
}

constexpr int kSize = 32;
constexpr int kLevels = 4;  // 32, 16, 8, 4 (the bake stops at 4²): ρ = 0, 1/3, 2/3, 1

TEST(EnvironmentSymmetry, TheHandDerivedFaceMapAgreesWithTheTexelDirections) {
  // The table above, checked against cubemap.h's texel directions: the rotated texel's direction, turned by
  // R_y(−90°), is the source texel's direction (to rounding).
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        const Vec3 d = texel_direction(f, x, y, kSize);
        const TexelRef s = rotated_source(f, x, y, kSize);
        const Vec3 e = texel_direction(s.face, s.x, s.y, kSize);
        ASSERT_NEAR(length(Vec3{-d.z, d.y, d.x} - e), 0.0, 1e-12) << f << " " << x << " " << y;
      }
}

const bake::BakeOutput& output(const EnvironmentBakeResult& r, const std::string& name) {
  for (const auto& o : r.outputs) {
    if (o.name == name) return o;
  }
  throw std::runtime_error("the bake wrote no " + name);
}

// The whole bake's small settings: a 32² chain of 4 levels, a fixed sample count (so that both bakes integrate with
// the same N), an 8² irradiance cube, a token DFG table.
EnvironmentBakeInput small_bake(double rotation_degrees, int samples) {
  EnvironmentBakeInput in;
  in.image = test_environment_exr();
  in.decode.rotation_degrees = rotation_degrees;
  in.size = kSize;
  in.levels = kLevels;
  in.samples = samples;
  in.irradiance_size = 8;
  in.dfg_size = 2;
  in.dfg_samples = 16;
  in.preview = false;
  return in;
}

// An EXR face of the bake as a cube face: values[y * n + x].
std::vector<Rgb> exr_face(const EnvironmentBakeResult& r, const std::string& name) {
  const image::FloatImage img = image::decode_exr(output(r, name).bytes);
  std::vector<Rgb> out;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) out.push_back({img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)});
  return out;
}

TEST(EnvironmentSymmetry, Rotating90DegreesPermutesAndTurnsEveryOutputFace) {
  const EnvironmentBakeResult a = bake_environment(small_bake(0.0, 1024));
  const EnvironmentBakeResult b = bake_environment(small_bake(90.0, 1024));
  EXPECT_TRUE(a.sun_found && b.sun_found);
  EXPECT_EQ(a.sun_texels, b.sun_texels);
  ASSERT_EQ(a.level_error.size(), static_cast<size_t>(kLevels));
  // Outputs are float: two doubles that agree to ~1e-13 (below) round to the same or adjacent floats, 2^-23
  // relative apart at most; 2^-22 leaves room for a double difference that straddles a float's rounding boundary.
  const double float_rounding = std::ldexp(1.0, -22);
  for (int k = 0; k < kLevels; ++k) {
    const int n = kSize >> k;
    // Level 0 is the resampled source, and the rotation is a whole-column shift of the equirect (16 of 64 columns),
    // so the rotated bake resamples the same values at the rotated directions: equal to rounding.
    // Levels k ≥ 1 are Monte Carlo estimates whose sample pattern is laid out in each texel's tangent frame
    // (Frame::from_normal), which does not turn with the environment: the two bakes integrate the same lobe with
    // differently oriented sample sets. Each deviates from the exact convolution by the level's reported relative
    // error e (error_estimate, an RMS over texels, noise and filtering bias); over ≤ 1536 texels the largest
    // deviation of a roughly normal error stays below 4 RMS (a 6e-5 tail), so |a − b| ≤ 4 (e_a + e_b) |a|.
    // Measured (1024 samples): max relative difference 0.0020, 0.0033, 0.0049 at levels 1–3, against bounds of
    // 0.019, 0.030, 0.026 (relative to the texel's largest channel); level 0 came out bit-identical.
    const double rel = k == 0 ? float_rounding : 4.0 * (a.level_error[k] + b.level_error[k]) + float_rounding;
    if (k > 0) {
      EXPECT_GT(a.level_error[k], 0.0) << "level " << k << " reports no error: the tolerance would be rounding only";
    }
    double worst = 0;
    std::array<std::vector<Rgb>, kFaceCount> fa, fb;
    for (int f = 0; f < kFaceCount; ++f) {
      const std::string name = "specular_L" + std::to_string(k) + "_" + std::string(kFaceNames[f]) + ".exr";
      fa[f] = exr_face(a, name);
      fb[f] = exr_face(b, name);
    }
    for (int f = 0; f < kFaceCount; ++f)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const TexelRef s = rotated_source(f, x, y, n);
          const Rgb va = fa[s.face][s.y * n + s.x], vb = fb[f][y * n + x];
          const double d = max_abs_diff(va, vb) / va.max();
          worst = std::max(worst, d);
          ASSERT_LE(d, rel) << "level " << k << ", rotated face " << kFaceNames[f] << " texel (" << x << ", " << y
                            << ") against face " << kFaceNames[s.face] << " (" << s.x << ", " << s.y << ")";
        }
    std::printf("level %d: max relative difference %.3g (tolerance %.3g)\n", k, worst, rel);
  }
  // The irradiance cube sums every source texel with exact weights: equivariant to rounding, like level 0.
  std::array<std::vector<Rgb>, kFaceCount> ia;
  for (int f = 0; f < kFaceCount; ++f) ia[f] = exr_face(a, "irradiance_" + std::string(kFaceNames[f]) + ".exr");
  for (int f = 0; f < kFaceCount; ++f) {
    const std::vector<Rgb> rotated = exr_face(b, "irradiance_" + std::string(kFaceNames[f]) + ".exr");
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const TexelRef s = rotated_source(f, x, y, 8);
        const Rgb va = ia[s.face][s.y * 8 + s.x];
        ASSERT_LE(max_abs_diff(va, rotated[y * 8 + x]) / va.max(), float_rounding)
            << "irradiance face " << kFaceNames[f] << " (" << x << ", " << y << ")";
      }
  }
}

TEST(EnvironmentSymmetry, RotationIsExactBeforeRoundingToFloat) {
  // The same in double precision on the lower-level functions, for level 0 (the source cube) and the irradiance:
  // the two computations differ only in the order of floating-point sums and atan2's rounding, ~1e-15 relative;
  // 1e-12 relative is that with three orders of margin (measured: ~6e-15 relative).
  EnvDecodeOptions opt;
  const EnvironmentInput env0 = decode_environment(test_environment_exr(), opt);
  opt.rotation_degrees = 90.0;
  const EnvironmentInput env90 = decode_environment(test_environment_exr(), opt);
  const Cubemap a = environment_to_cube(env0, kSize), b = environment_to_cube(env90, kSize);
  const Cubemap ia = irradiance_cubemap(a, 8), ib = irradiance_cubemap(b, 8);
  for (int f = 0; f < kFaceCount; ++f) {
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        const TexelRef s = rotated_source(f, x, y, kSize);
        ASSERT_LE(max_abs_diff(a.at(s.face, s.x, s.y), b.at(f, x, y)), 1e-12 * a.at(s.face, s.x, s.y).max())
            << f << " " << x << " " << y;
      }
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const TexelRef s = rotated_source(f, x, y, 8);
        ASSERT_LE(max_abs_diff(ia.at(s.face, s.x, s.y), ib.at(f, x, y)), 1e-12 * ia.at(s.face, s.x, s.y).max());
      }
  }
}

// ---- edges -------------------------------------------------------------------------------------------------------
//
// For every face F and each of its four edges, every texel p touching the edge is paired with the texel q across it:
// the texel of the neighbouring face G (the major axis of p's plane extended one texel outwards) whose centre is
// nearest to p's. Both orientations of each of the 12 edges are visited (F → G and G → F). The difference
// |L(p) − L(q)| is compared with the differences between neighbouring texels inside the faces around that place.

int major_face(const Vec3& d) {
  const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  if (ax >= ay && ax >= az) return d.x > 0 ? 0 : 1;
  if (ay >= az) return d.y > 0 ? 2 : 3;
  return d.z > 0 ? 4 : 5;
}

struct EdgePair {
  TexelRef p, q;
};

std::vector<EdgePair> edge_pairs(int n) {
  std::vector<EdgePair> pairs;
  const int steps[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
  for (int f = 0; f < kFaceCount; ++f) {
    for (const auto& st : steps) {
      for (int i = 0; i < n; ++i) {
        const int x = st[0] == 0 ? i : (st[0] < 0 ? 0 : n - 1);
        const int y = st[1] == 0 ? i : (st[1] < 0 ? 0 : n - 1);
        const Vec3 outside = face_uv_to_direction(f, (x + 0.5 + st[0]) / n, (y + 0.5 + st[1]) / n);
        const int g = major_face(outside);
        const Vec3 dp = texel_direction(f, x, y, n);
        TexelRef best{g, 0, 0};
        double best_dot = -2;
        for (int yy = 0; yy < n; ++yy)
          for (int xx = 0; xx < n; ++xx) {
            const double c = dot(dp, texel_direction(g, xx, yy, n));
            if (c > best_dot) best_dot = c, best = {g, xx, yy};
          }
        pairs.push_back({{f, x, y}, best});
      }
    }
  }
  return pairs;
}

// The largest difference between in-face 4-neighbours among the texels within `radius` of t (Chebyshev) on t's face.
double local_interior_difference(const Cubemap& c, const TexelRef& t, int radius) {
  const int n = c.size();
  double worst = 0;
  for (int y = std::max(0, t.y - radius); y <= std::min(n - 1, t.y + radius); ++y)
    for (int x = std::max(0, t.x - radius); x <= std::min(n - 1, t.x + radius); ++x) {
      if (x + 1 < n) worst = std::max(worst, max_abs_diff(c.at(t.face, x, y), c.at(t.face, x + 1, y)));
      if (y + 1 < n) worst = std::max(worst, max_abs_diff(c.at(t.face, x, y), c.at(t.face, x, y + 1)));
    }
  return worst;
}

// One bake shared by the edge and container tests (the default sample choice: from the target error).
const EnvironmentBakeResult& shared_bake() {
  static const EnvironmentBakeResult result = [] {
    EnvironmentBakeInput in = small_bake(0.0, 0);
    return bake_environment(in);
  }();
  return result;
}

TEST(EnvironmentSymmetry, TheTestEnvironmentHasASun) {
  // Not a symmetry: the precondition that the bakes above and below go through the sky/sun split.
  EXPECT_TRUE(shared_bake().sun_found);
  EXPECT_GT(shared_bake().sun_texels, 0);
}

Cubemap level_cube(const EnvironmentBakeResult& r, int k) {
  const int n = kSize >> k;
  Cubemap c(n);
  for (int f = 0; f < kFaceCount; ++f)
    c.face(f) = exr_face(r, "specular_L" + std::to_string(k) + "_" + std::string(kFaceNames[f]) + ".exr");
  return c;
}

// Measured over the pairs of every level (the largest edge difference / local interior difference): 0.95, 0.89,
// 0.68, 0.81 at levels 0–3; the control below gives 19.7. Along an edge the two texel centres are 1/N radians apart, as
// far as in-face neighbours next to the edge (plane spacing 2/N at a slope of 1/(1 + a²) = ½), so a seamless map has
// ratios near 1 or below; 1.5 leaves room for a gradient that is steeper across the edge than along it, and catches a
// seam (a face turned or shifted by one texel gives ratios of several, see the control below).
constexpr double kEdgeRatio = 1.5;

double worst_edge_ratio(const Cubemap& c, TexelRef* where = nullptr) {
  double worst = 0;
  for (const EdgePair& e : edge_pairs(c.size())) {
    const double edge = max_abs_diff(c.at(e.p.face, e.p.x, e.p.y), c.at(e.q.face, e.q.x, e.q.y));
    const double interior = std::max(local_interior_difference(c, e.p, 1), local_interior_difference(c, e.q, 1));
    // A locally flat map (interior 0) must be flat across the edge too: the ratio is then 0/0 → 0 or x/0 → inf.
    const double ratio = edge == 0.0 ? 0.0 : edge / interior;
    if (ratio > worst) {
      worst = ratio;
      if (where) *where = e.p;
    }
  }
  return worst;
}

TEST(EnvironmentSymmetry, EdgePairsAreTheTexelsAcrossTheEdge) {
  for (int n : {2, 4, 32}) {
    const std::vector<EdgePair> pairs = edge_pairs(n);
    // 6 faces × 4 edges × n texels: each of the 12 edges from both sides.
    ASSERT_EQ(pairs.size(), static_cast<size_t>(24 * n));
    for (const EdgePair& e : pairs) {
      ASSERT_NE(e.p.face, e.q.face);
      // q lies on the border of its face, and its centre is about one texel (1/N rad at an edge) from p's.
      ASSERT_TRUE(e.q.x == 0 || e.q.y == 0 || e.q.x == n - 1 || e.q.y == n - 1);
      const double angle = std::acos(std::clamp(
          dot(texel_direction(e.p.face, e.p.x, e.p.y, n), texel_direction(e.q.face, e.q.x, e.q.y, n)), -1.0, 1.0));
      ASSERT_LT(angle, 1.5 * 2.0 / n) << n;
    }
  }
}

TEST(EnvironmentSymmetry, TexelsAcrossEveryEdgeAgreeLikeNeighboursInsideAFace) {
  const EnvironmentBakeResult& r = shared_bake();
  for (int k = 0; k < kLevels; ++k) {
    const Cubemap c = level_cube(r, k);
    TexelRef where{};
    const double ratio = worst_edge_ratio(c, &where);
    std::printf("level %d size %d: largest edge / local interior difference %.3g\n", k, c.size(), ratio);
    EXPECT_LE(ratio, kEdgeRatio) << "level " << k << ": a seam at face " << kFaceNames[where.face] << " texel ("
                                 << where.x << ", " << where.y << ")";
  }
  // Control: the check sees a seam. Face +Y of level 0 turned by 90° in its plane (a wrong orientation convention)
  // breaks every edge of that face.
  Cubemap wrong = level_cube(r, 0);
  const Cubemap right = wrong;
  const int n = wrong.size();
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) wrong.at(2, x, y) = right.at(2, y, n - 1 - x);
  const double control = worst_edge_ratio(wrong);
  std::printf("control (+Y turned by 90 degrees): %.3g\n", control);
  EXPECT_GT(control, 2.0 * kEdgeRatio);
}

// ---- the container -------------------------------------------------------------------------------------------------

TEST(EnvironmentSymmetry, Ktx2HoldsEveryLevelAndFaceOfTheExrFaces) {
  const EnvironmentBakeResult& r = shared_bake();
  const image::Ktx2Image ktx = image::decode_ktx2(output(r, "specular.ktx2").bytes);
  ASSERT_EQ(ktx.width, kSize);
  ASSERT_EQ(ktx.height, kSize);
  ASSERT_EQ(ktx.faces, 6);
  ASSERT_EQ(ktx.levels, kLevels);
  ASSERT_EQ(ktx.format, image::Ktx2Image::rgba16f);
  // Key/value data.
  EXPECT_EQ(ktx.key_values.at("KTXorientation"), "rd");
  EXPECT_EQ(ktx.key_values.at("KTXwriter"), "kiln");
  EXPECT_EQ(ktx.key_values.at("kiln:cubemap_convention"), std::string(kCubemapConvention));
  EXPECT_EQ(ktx.key_values.at("kiln:color_space"), "lin_rec709");
  EXPECT_EQ(ktx.key_values.at("kiln:lobe"), "ggx");
  EXPECT_NE(ktx.key_values.at("kiln:roughness_mapping").find("rho^2"), std::string::npos);
  for (const auto& [key, value] : ktx.key_values) EXPECT_FALSE(value.empty()) << key;
  std::istringstream roughness(ktx.key_values.at("kiln:roughness_per_level"));
  std::string item;
  std::vector<double> rho;
  while (std::getline(roughness, item, ',')) rho.push_back(std::stod(item));
  ASSERT_EQ(rho.size(), static_cast<size_t>(kLevels));
  for (int k = 0; k < kLevels; ++k) {
    // Printed with round-trip precision (format_number): the level's ρ = k/(L − 1) exactly.
    EXPECT_EQ(rho[k], r.level_roughness[k]);
    EXPECT_DOUBLE_EQ(rho[k], k / (kLevels - 1.0));
  }
  // Pixels: the KTX holds RGBA16F, the EXR faces RGB float32 of the same doubles. The KTX value must be the correctly
  // rounded half of the EXR's float (float → half is the second rounding of the same double; KTX2's own tests prove
  // float_to_half against IEEE 754), which is within 2^-11 relative of it for normal halves (|v| ≥ 2^-14; the values
  // here are > 0.1). Alpha is 1.
  for (int k = 0; k < kLevels; ++k) {
    const int n = kSize >> k;
    ASSERT_EQ(ktx.level_width(k), n);
    for (int f = 0; f < kFaceCount; ++f) {
      const std::string name = "specular_L" + std::to_string(k) + "_" + std::string(kFaceNames[f]) + ".exr";
      const image::FloatImage exr = image::decode_exr(output(r, name).bytes);
      ASSERT_EQ(exr.width, n);
      ASSERT_EQ(exr.height, n);
      EXPECT_EQ(exr.metadata.at("kiln:face"), std::string(kFaceNames[f]));
      EXPECT_EQ(exr.metadata.at("kiln:cubemap_convention"), std::string(kCubemapConvention));
      const std::vector<float>& px = ktx.image(k, f);
      ASSERT_EQ(px.size(), static_cast<size_t>(n) * n * 4);
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const float* h = &px[(static_cast<size_t>(y) * n + x) * 4];
          for (int c = 0; c < 3; ++c) {
            const float e = exr.at(x, y, c);
            ASSERT_EQ(h[c], image::half_to_float(image::float_to_half(e)))
                << name << " (" << x << ", " << y << ") channel " << c;
            ASSERT_LE(std::abs(h[c] - e), std::ldexp(std::abs(e), -11)) << name;
          }
          ASSERT_EQ(h[3], 1.0f);
        }
    }
  }
}

}  // namespace
}  // namespace kiln::envmap
