#include "bakers/plan/media_analysis.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/volume/medium_overlap.h"
#include "bakers/volume/medium_sum.h"
#include "bakers/volume/tracking.h"

namespace kiln::plan {
namespace {

// The largest single-scattering albedo of a medium's coefficients (per unit density for a grid: the density cancels).
double albedo_of(const Rgb& sigma_a, const Rgb& sigma_s) {
  double a = 0;
  for (int c = 0; c < 3; ++c) {
    const double t = sigma_a[c] + sigma_s[c];
    if (t > 0) a = std::max(a, sigma_s[c] / t);
  }
  return a;
}

void read_coefficients(const volume::MediumInput& in, MediaAnalysis& out) {
  if (const auto* h = std::get_if<volume::HomogeneousMediumSpec>(&in.spec)) {
    out.albedo = std::max(out.albedo, albedo_of(h->sigma_a, h->sigma_s));
    out.emissive = out.emissive || (h->Le.max() > 0 && h->sigma_a.max() > 0);
  } else {
    const auto& g = std::get<volume::GridMediumSpec>(in.spec);
    out.albedo = std::max(out.albedo, albedo_of(g.sigma_a, g.sigma_s));
    out.emissive = out.emissive || (g.emission && g.Le_scale.max() > 0 && g.sigma_a.max() > 0);
  }
}

// The end of a light path from p: a light's position, or infinitely far along a direction (tmax = ∞).
scene::Ray towards_light(const scene::Scene& scene, const Vec3& p, int path, Pcg32& rng) {
  const int lights = static_cast<int>(scene.lights.size());
  if (lights > 0 && path % (lights + 1) < lights) {
    const scene::Light& l = scene.lights[path % (lights + 1)];
    if (l.type == scene::LightShape::directional) return {p, -l.direction, INFINITY};
    return {p, l.position - p, 1.0};
  }
  return {p, sample_uniform_sphere({rng.uniform(), rng.uniform()}), INFINITY};  // the sky, or between surfaces
}

Vec3 uniform_in(const Vec3& lo, const Vec3& hi, Pcg32& rng) {
  return {lo.x + (hi.x - lo.x) * rng.uniform(), lo.y + (hi.y - lo.y) * rng.uniform(),
          lo.z + (hi.z - lo.z) * rng.uniform()};
}

// 1 − mean transmittance along `paths` light paths, in the channel that loses most, with its standard error.
void sample_extinction(const scene::Scene& scene, const volume::Medium& medium, int paths, MediaAnalysis& out) {
  Vec3 lo, hi;
  if (!scene::scene_box(scene, lo, hi)) return;
  Pcg32 rng(0x6d65646961ULL);
  Rgb sum, sum2;
  for (int i = 0; i < paths; ++i) {
    const Vec3 p = uniform_in(lo, hi, rng);
    // Every other path ends at another point of the scene: light between surfaces.
    const scene::Ray ray =
        i % 2 ? scene::Ray{p, uniform_in(lo, hi, rng) - p, 1.0} : towards_light(scene, p, i / 2, rng);
    const Rgb T = volume::ratio_tracking_transmittance(medium, ray, ray.tmax, rng);
    sum += T;
    sum2 += T * T;
  }
  const Rgb mean = sum / paths;
  int worst = 0;
  for (int c = 1; c < 3; ++c) worst = mean[c] < mean[worst] ? c : worst;
  out.paths = paths;
  out.extinction = 1 - mean[worst];
  const double variance = std::max(0.0, sum2[worst] / paths - mean[worst] * mean[worst]);
  out.extinction_error = std::sqrt(variance / std::max(1, paths - 1));
}

}  // namespace

MediaAnalysis analyse_media(const scene::Scene& scene, const std::vector<volume::MediumInput>& inputs,
                            const std::vector<const volume::Medium*>& media, int paths) {
  MediaAnalysis out;
  volume::Bounds3 box;
  const bool bounded = scene::scene_box(scene, box.lo, box.hi);
  for (size_t i = 0; i < media.size(); ++i) {
    const std::string who =
        "media[" + std::to_string(i) + "]" + (inputs[i].name.empty() ? "" : " '" + inputs[i].name + "'");
    if (bounded) {
      if (auto why = volume::outside_scene(*media[i], box)) {
        out.skipped.push_back(who + ": " + *why);
        continue;
      }
    }
    out.active.push_back(media[i]);
    out.active_index.push_back(static_cast<int>(i));
    read_coefficients(inputs[i], out);
  }
  if (out.active.empty()) return out;
  const std::unique_ptr<volume::MediumSum> sum =
      out.active.size() > 1 ? std::make_unique<volume::MediumSum>(out.active) : nullptr;
  sample_extinction(scene, sum ? *sum : *out.active[0], paths, out);
  return out;
}

}  // namespace kiln::plan
