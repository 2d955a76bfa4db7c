#include "bakers/envmap/sun.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "bakers/bake/number_format.h"
#include "bakers/envmap/irradiance.h"

namespace kiln::envmap {
namespace {

// The texel (f2, x2, y2) at offset (dx, dy) of (face, x, y), across an edge when it leaves the face (the texel that
// touches the edge at the same place; at a corner, the one the diagonal direction falls in).
void neighbour(int face, int x, int y, int dx, int dy, int n, int& f2, int& x2, int& y2) {
  if (x + dx >= 0 && x + dx < n && y + dy >= 0 && y + dy < n) {
    f2 = face, x2 = x + dx, y2 = y + dy;
    return;
  }
  const FaceUv f = direction_to_face_uv(face_uv_to_direction(face, (x + dx + 0.5) / n, (y + dy + 0.5) / n));
  f2 = f.face;
  x2 = std::clamp(static_cast<int>(std::floor(f.u * n)), 0, n - 1);
  y2 = std::clamp(static_cast<int>(std::floor(f.v * n)), 0, n - 1);
}

template <class Fn>
void for_each_texel(Cubemap& out, Fn&& fn) {
  const int size = out.size(), per_face = size * size;
  tbb::parallel_for(tbb::blocked_range<int>(0, kFaceCount * per_face), [&](const tbb::blocked_range<int>& r) {
    for (int idx = r.begin(); idx != r.end(); ++idx) {
      const int face = idx / per_face, rem = idx % per_face, x = rem % size, y = rem / size;
      out.at(face, x, y) += fn(texel_direction(face, x, y, size));
    }
  });
}

// A texel of a cube of size n by its index (face-major, then row, then column).
struct TexelIndex {
  int face, x, y;
};
TexelIndex texel_at(size_t i, int n) {
  const size_t per_face = static_cast<size_t>(n) * n;
  const int rem = static_cast<int>(i % per_face);
  return {static_cast<int>(i / per_face), rem % n, rem / n};
}

// Per texel, by index: the luminance Y and the exact solid angle, and the sums ∫ Y dω and ∫ dω.
struct LuminanceMap {
  std::vector<double> y, omega;
  double total_power = 0, total_omega = 0;
};

LuminanceMap measure_luminance(const Cubemap& source) {
  const int n = source.size();
  const size_t count = static_cast<size_t>(kFaceCount) * n * n;
  LuminanceMap m;
  m.y.resize(count);
  m.omega.resize(count);
  const std::vector<double>& omega = *texel_solid_angles(n);
  for (int f = 0; f < kFaceCount; ++f)
    for (int ty = 0; ty < n; ++ty)
      for (int tx = 0; tx < n; ++tx) {
        const size_t i = (static_cast<size_t>(f) * n + ty) * n + tx;
        m.y[i] = luminance(source.at(f, tx, ty));
        m.omega[i] = omega[static_cast<size_t>(ty) * n + tx];
        m.total_power += m.y[i] * m.omega[i];
        m.total_omega += m.omega[i];
      }
  return m;
}

// The texels above the threshold T = kSunContrast · Q, brightest first, at most kMaxSunTexels; sets Q, T and the
// candidate count of `s`.
std::vector<size_t> pick_sun_texels(const LuminanceMap& m, SunSplit& s) {
  const std::vector<double>& y = m.y;
  // Q: the solid-angle-weighted 90th percentile of Y.
  std::vector<size_t> order(y.size());
  std::iota(order.begin(), order.end(), size_t{0});
  // Ties broken by index: the same map always picks the same texels (the same input and seed give the same bytes).
  tbb::parallel_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return y[a] < y[b] || (y[a] == y[b] && a < b); });
  double acc = 0;
  for (size_t i : order) {
    acc += m.omega[i];
    s.quantile_luminance = y[i];
    if (acc >= kSunQuantile * m.total_omega) break;
  }
  s.threshold = kSunContrast * s.quantile_luminance;
  std::vector<size_t> picked;
  for (auto it = order.rbegin(); it != order.rend() && y[*it] > s.threshold; ++it) {
    ++s.candidates;
    if (static_cast<int>(picked.size()) < kMaxSunTexels) picked.push_back(*it);
  }
  return picked;
}

// Whether the picked texels are used as the sun (s.enabled), with the power fraction and the reason in words.
void decide_sun(const LuminanceMap& m, const std::vector<size_t>& picked, SunMode mode, SunSplit& s) {
  double sun_power = 0;
  for (size_t i : picked) sun_power += m.y[i] * m.omega[i];
  s.power_fraction = m.total_power > 0 ? sun_power / m.total_power : 0.0;
  const std::string rule = "texels with luminance > " + bake::format_number(kSunContrast) + " x the 90th percentile (" +
                           bake::format_number(s.quantile_luminance) + ") = " + bake::format_number(s.threshold);
  if (picked.empty()) {
    s.reason = (mode == SunMode::forced_on ? "forced on, but no sun found (no-op): no " : "no sun: no ") + rule;
    return;
  }
  const std::string found = std::to_string(picked.size()) + " texel(s) " + rule +
                            (s.candidates > kMaxSunTexels ? " (the brightest " + std::to_string(kMaxSunTexels) +
                                                                " of " + std::to_string(s.candidates) + ")"
                                                          : std::string()) +
                            ", holding " + bake::format_number(100.0 * s.power_fraction) + "% of the power";
  if (mode == SunMode::automatic && s.power_fraction < kMinSunPowerFraction) {
    s.reason = "no sun: " + found + ", below the " + bake::format_number(100.0 * kMinSunPowerFraction) +
               "% that makes a separate light worth its cost";
    return;
  }
  s.enabled = true;
  s.reason = (mode == SunMode::forced_on ? "forced on: " : "sun found: ") + found +
             "; taken out of the sampled map and added exactly to every output";
}

// Fills the sun texels' sky from their non-sun neighbours, peeling the sun from its border inwards.
void fill_sky_under_sun(SunSplit& s, const Cubemap& source, const std::vector<size_t>& picked,
                        const std::vector<double>& y) {
  const int n = source.size();
  std::vector<char> filled(y.size(), 1);
  for (size_t i : picked) filled[i] = 0;
  std::vector<size_t> pending(picked);
  std::vector<std::pair<size_t, Rgb>> fills;
  while (!pending.empty()) {
    fills.clear();
    std::vector<size_t> still;
    for (size_t i : pending) {
      const TexelIndex t = texel_at(i, n);
      Rgb sum;
      int k = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (!dx && !dy) continue;
          int f2, x2, y2;
          neighbour(t.face, t.x, t.y, dx, dy, n, f2, x2, y2);
          const size_t j = (static_cast<size_t>(f2) * n + y2) * n + x2;
          if (filled[j]) sum += s.sky.at(f2, x2, y2), ++k;
        }
      if (k > 0)
        fills.push_back({i, sum / k});
      else
        still.push_back(i);
    }
    // Every sun texel is non-sun or next to one after at most the sun's radius in passes; a map that is all sun (a
    // cube of a few texels) has none: its sky keeps the texel scaled down to the threshold.
    if (fills.empty()) {
      for (size_t i : still) {
        const TexelIndex t = texel_at(i, n);
        const double scale = y[i] > 0 ? std::min(1.0, s.threshold / y[i]) : 0.0;
        fills.push_back({i, source.at(t.face, t.x, t.y) * scale});
      }
      still.clear();
    }
    for (const auto& [i, v] : fills) {
      const TexelIndex t = texel_at(i, n);
      s.sky.at(t.face, t.x, t.y) = v;
      filled[i] = 1;
    }
    pending = std::move(still);
  }
}

// The sun texels: each keeps what its texel has above the sky.
void take_out_sun(SunSplit& s, const Cubemap& source, const std::vector<size_t>& picked,
                  const std::vector<double>& omega) {
  const int n = source.size();
  for (size_t i : picked) {
    const TexelIndex t = texel_at(i, n);
    const Rgb& l = source.at(t.face, t.x, t.y);
    Rgb& sky = s.sky.at(t.face, t.x, t.y);
    // The sky is never above the texel itself, so the sun's part is ≥ 0 in every channel.
    sky = Rgb(std::min(sky.r, l.r), std::min(sky.g, l.g), std::min(sky.b, l.b));
    s.sun.push_back({t.face, t.x, t.y, texel_direction(t.face, t.x, t.y, n), omega[i], l - sky});
  }
}

}  // namespace

SunSplit split_sun(const Cubemap& source, SunMode mode) {
  SunSplit s;
  s.sky = source;
  const LuminanceMap m = measure_luminance(source);
  if (mode == SunMode::forced_off) {
    s.reason = "forced off: the whole map, sun included, is importance sampled";
    return s;
  }
  const std::vector<size_t> picked = pick_sun_texels(m, s);
  decide_sun(m, picked, mode, s);
  if (!s.enabled) return s;
  fill_sky_under_sun(s, source, picked, m.y);
  take_out_sun(s, source, picked, m.omega);
  return s;
}

Rgb sun_specular_at(const std::vector<SunTexel>& sun, const SplitSumLobe& lobe, double normalization, const Vec3& n) {
  Rgb sum;
  for (const SunTexel& t : sun) sum += t.radiance * (lobe.weight(n, t.dir) * t.solid_angle);
  return sum / normalization;
}

void add_sun_specular(Cubemap& out, const std::vector<SunTexel>& sun, const SplitSumLobe& lobe, double normalization) {
  if (sun.empty()) return;
  for_each_texel(out, [&](const Vec3& n) { return sun_specular_at(sun, lobe, normalization, n); });
}

Rgb sun_irradiance_at(const std::vector<SunTexel>& sun, const Vec3& n) {
  Rgb sum;
  for (const SunTexel& t : sun) sum += t.radiance * (std::max(0.0, dot(n, t.dir)) * t.solid_angle);
  return sum;
}

void add_sun_irradiance(Cubemap& out, const std::vector<SunTexel>& sun) {
  if (sun.empty()) return;
  for_each_texel(out, [&](const Vec3& n) { return sun_irradiance_at(sun, n); });
}

void deposit_sun(Cubemap& out, const std::vector<SunTexel>& sun) {
  const int n = out.size();
  for (const SunTexel& t : sun) {
    const FaceUv f = direction_to_face_uv(t.dir);
    const int x = std::clamp(static_cast<int>(std::floor(f.u * n)), 0, n - 1);
    const int y = std::clamp(static_cast<int>(std::floor(f.v * n)), 0, n - 1);
    out.at(f.face, x, y) += t.radiance * (t.solid_angle / texel_solid_angle(x, y, n));
  }
}

Cubemap irradiance_with_sun(const Cubemap& sky, const std::vector<SunTexel>& sun, int out_size, int max_source_size) {
  Cubemap small = sky;
  while (small.size() > max_source_size && small.size() % 2 == 0) small = downsample_2x(small);
  Cubemap irradiance = irradiance_cubemap(small, out_size);
  add_sun_irradiance(irradiance, sun);
  return irradiance;
}

ShCoefficients project_sh_with_sun(const Cubemap& sky, const std::vector<SunTexel>& sun) {
  ShCoefficients c = project_sh(sky);
  for (const SunTexel& t : sun) {
    const ShBasis b = sh_basis(t.dir);
    for (int i = 0; i < kShCount; ++i) c[i] += t.radiance * (t.solid_angle * b[i]);
  }
  return c;
}

}  // namespace kiln::envmap
