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

}  // namespace


SunSplit split_sun(const Cubemap& source, SunMode mode) {
  SunSplit s;
  s.sky = source;
  const int n = source.size();
  const size_t count = static_cast<size_t>(kFaceCount) * n * n;
  std::vector<double> y(count), omega(count);
  double total_power = 0, total_omega = 0;
  for (int f = 0; f < kFaceCount; ++f)
    for (int ty = 0; ty < n; ++ty)
      for (int tx = 0; tx < n; ++tx) {
        const size_t i = (static_cast<size_t>(f) * n + ty) * n + tx;
        y[i] = luminance(source.at(f, tx, ty));
        omega[i] = texel_solid_angle(tx, ty, n);
        total_power += y[i] * omega[i];
        total_omega += omega[i];
      }
  if (mode == SunMode::forced_off) {
    s.reason = "forced off: the whole map, sun included, is importance sampled";
    return s;
  }
  // Q: the solid-angle-weighted 90th percentile of Y.
  std::vector<size_t> order(count);
  std::iota(order.begin(), order.end(), size_t{0});
  // Ties broken by index: the same map always picks the same texels (the same input and seed give the same bytes).
  tbb::parallel_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return y[a] < y[b] || (y[a] == y[b] && a < b); });
  double acc = 0;
  for (size_t i : order) {
    acc += omega[i];
    s.quantile_luminance = y[i];
    if (acc >= kSunQuantile * total_omega) break;
  }
  s.threshold = kSunContrast * s.quantile_luminance;
  std::vector<size_t> picked;
  for (auto it = order.rbegin(); it != order.rend() && y[*it] > s.threshold; ++it) {
    ++s.candidates;
    if (static_cast<int>(picked.size()) < kMaxSunTexels) picked.push_back(*it);
  }
  double sun_power = 0;
  for (size_t i : picked) sun_power += y[i] * omega[i];
  s.power_fraction = total_power > 0 ? sun_power / total_power : 0.0;
  const std::string rule = "texels with luminance > " + bake::format_number(kSunContrast) + " x the 90th percentile (" +
                           bake::format_number(s.quantile_luminance) + ") = " + bake::format_number(s.threshold);
  if (picked.empty()) {
    s.reason = (mode == SunMode::forced_on ? "forced on, but no sun found (no-op): no " : "no sun: no ") + rule;
    return s;
  }
  const std::string found = std::to_string(picked.size()) + " texel(s) " + rule +
                            (s.candidates > kMaxSunTexels ? " (the brightest " + std::to_string(kMaxSunTexels) +
                                                                " of " + std::to_string(s.candidates) + ")"
                                                          : std::string()) +
                            ", holding " + bake::format_number(100.0 * s.power_fraction) + "% of the power";
  if (mode == SunMode::automatic && s.power_fraction < kMinSunPowerFraction) {
    s.reason = "no sun: " + found + ", below the " + bake::format_number(100.0 * kMinSunPowerFraction) +
               "% that makes a separate light worth its cost";
    return s;
  }
  s.enabled = true;
  s.reason = (mode == SunMode::forced_on ? "forced on: " : "sun found: ") + found +
             "; taken out of the sampled map and added exactly to every output";

  // Fill the sun texels' sky from their non-sun neighbours, peeling the sun from its border inwards.
  std::vector<char> is_sun(count, 0), filled(count, 1);
  for (size_t i : picked) is_sun[i] = 1, filled[i] = 0;
  std::vector<size_t> pending(picked);
  std::vector<std::pair<size_t, Rgb>> fills;
  while (!pending.empty()) {
    fills.clear();
    std::vector<size_t> still;
    for (size_t i : pending) {
      const int f = static_cast<int>(i / (static_cast<size_t>(n) * n)), rem = static_cast<int>(i % (size_t(n) * n));
      const int tx = rem % n, ty = rem / n;
      Rgb sum;
      int k = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (!dx && !dy) continue;
          int f2, x2, y2;
          neighbour(f, tx, ty, dx, dy, n, f2, x2, y2);
          const size_t j = (static_cast<size_t>(f2) * n + y2) * n + x2;
          if (filled[j]) sum += s.sky.at(f2, x2, y2), ++k;
        }
      if (k > 0) fills.push_back({i, sum / k});
      else still.push_back(i);
    }
    // Every sun texel is non-sun or next to one after at most the sun's radius in passes; a map that is all sun (a
    // cube of a few texels) has none: its sky keeps the texel scaled down to the threshold.
    if (fills.empty()) {
      for (size_t i : still) {
        const int f = static_cast<int>(i / (size_t(n) * n)), rem = static_cast<int>(i % (size_t(n) * n));
        const double scale = y[i] > 0 ? std::min(1.0, s.threshold / y[i]) : 0.0;
        fills.push_back({i, source.at(f, rem % n, rem / n) * scale});
      }
      still.clear();
    }
    for (const auto& [i, v] : fills) {
      const int f = static_cast<int>(i / (size_t(n) * n)), rem = static_cast<int>(i % (size_t(n) * n));
      s.sky.at(f, rem % n, rem / n) = v;
      filled[i] = 1;
    }
    pending = std::move(still);
  }
  for (size_t i : picked) {
    const int f = static_cast<int>(i / (size_t(n) * n)), rem = static_cast<int>(i % (size_t(n) * n));
    const int tx = rem % n, ty = rem / n;
    const Rgb& l = source.at(f, tx, ty);
    Rgb& sky = s.sky.at(f, tx, ty);
    // The sky is never above the texel itself, so the sun's part is ≥ 0 in every channel.
    sky = Rgb(std::min(sky.r, l.r), std::min(sky.g, l.g), std::min(sky.b, l.b));
    s.sun.push_back({f, tx, ty, texel_direction(f, tx, ty, n), omega[i], l - sky});
  }
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
