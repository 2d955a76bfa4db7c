#include "bakers/scene/light_sampler.h"

#include <algorithm>
#include <cmath>

#include "bakers/scene/area_lights.h"
#include "bakers/scene/punctual_lights.h"

namespace kiln::scene {

bool scene_box(const Scene& scene, Vec3& lo, Vec3& hi) {
  lo = {kInfinity, kInfinity, kInfinity};
  hi = -lo;
  bool any = false;
  const auto grow = [&](const Vec3& p) {
    if (!is_finite(p)) return;  // NaN vertices are reported elsewhere; they must not poison the bound
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    any = true;
  };
  for (const Instance& inst : scene.instances) {
    if (inst.mesh < 0 || inst.mesh >= static_cast<int>(scene.meshes.size())) continue;
    for (const Vec3& p : scene.meshes[inst.mesh].positions) grow(inst.to_world.point(p));
  }
  for (const Light& l : scene.lights) {
    if (l.type != LightShape::directional) grow(l.position);
  }
  return any;
}

double scene_bounding_radius(const Scene& scene) {
  Vec3 lo, hi;
  if (!scene_box(scene, lo, hi)) return 1.0;
  const double r = 0.5 * length(hi - lo);
  // A scene that is a single point has no size: 1 keeps the infinite lights' power (π R² E) non-zero.
  return (r > 0 && std::isfinite(r)) ? r : 1.0;
}

std::unique_ptr<LightSource> make_light(const Light& l) {
  switch (l.type) {
    case LightShape::point:
      return std::make_unique<PointLight>(l.position, l.color);
    case LightShape::spot:
      return std::make_unique<SpotLight>(l.position, l.direction, l.color, l.inner_cone, l.outer_cone);
    case LightShape::directional:
      return std::make_unique<DirectionalLight>(l.direction, l.color, l.angular_diameter);
    case LightShape::rect:
      return std::make_unique<RectLight>(l.position, l.u_axis, l.v_axis, l.direction, l.color, l.two_sided);
    case LightShape::disk:
      return std::make_unique<DiskLight>(l.position, l.direction, l.radius, l.color, l.two_sided);
  }
  return std::make_unique<PointLight>(l.position, Rgb{});  // unreachable for a valid LightShape: a black light
}

SceneLights::SceneLights(const Scene& scene, const LightSamplingOptions& options)
    : radius_(scene_bounding_radius(scene)) {
  std::vector<bool> sampled;
  for (const Light& l : scene.lights) {
    lights_.push_back(make_light(l));
    bool on = true;
    switch (l.type) {
      case LightShape::point:
        on = options.point_lights;
        break;
      case LightShape::spot:
        on = options.spot_lights;
        break;
      case LightShape::directional:
        on = options.directional_lights;
        break;
      case LightShape::rect:
      case LightShape::disk:
        on = options.area_lights;
        break;
    }
    sampled.push_back(on);
  }
  auto emissive = std::make_unique<EmissiveTriangles>(EmissiveTriangles::from_scene(scene));
  if (!emissive->empty()) {
    emissive_ = emissive.get();
    lights_.push_back(std::move(emissive));
    sampled.push_back(options.emissive_triangles);
  }
  if (scene.environment.present()) {
    auto env = std::make_unique<EnvironmentLight>(scene.environment, options.environment_importance_map);
    environment_ = env.get();
    lights_.push_back(std::move(env));
    sampled.push_back(options.environment);
  }
  build_distribution(sampled, options.choice);
}

SceneLights::SceneLights(std::vector<std::unique_ptr<LightSource>> lights, double scene_radius, LightChoice choice)
    : lights_(std::move(lights)), radius_(scene_radius > 0 && std::isfinite(scene_radius) ? scene_radius : 1.0) {
  for (const auto& l : lights_) {
    if (l->kind() == LightSamplerKind::environment) environment_ = static_cast<const EnvironmentLight*>(l.get());
    if (l->kind() == LightSamplerKind::emissive_triangles) emissive_ = static_cast<const EmissiveTriangles*>(l.get());
  }
  build_distribution(std::vector<bool>(lights_.size(), true), choice);
}

void SceneLights::build_distribution(const std::vector<bool>& sampled, LightChoice choice) {
  std::vector<double> weights(lights_.size(), 0.0);
  for (size_t i = 0; i < lights_.size(); ++i) {
    if (lights_[i]->is_infinite() && !lights_[i]->is_delta()) escape_.push_back(static_cast<int>(i));
    if (!sampled[i]) continue;
    const double phi = luminance(lights_[i]->power(radius_));
    // Zero power (a black light) is never chosen, under either rule; a non-finite estimate is not a weight.
    if (!(phi > 0) || !std::isfinite(phi)) continue;
    weights[i] = choice == LightChoice::power ? phi : 1.0;
  }
  distribution_ = AliasTable(weights);
  any_ = distribution_.total() > 0;
  // The common case of one light to sample (a single sun, area light or emissive mesh): chosen with pmf 1 without
  // searching the distribution, and u passes through whole.
  single_ = -1;
  if (any_ && std::count_if(weights.begin(), weights.end(), [](double w) { return w > 0; }) == 1) {
    single_ = static_cast<int>(std::find_if(weights.begin(), weights.end(), [](double w) { return w > 0; }) -
                               weights.begin());
  }
}

int SceneLights::index_of(const LightSource* light) const {
  for (size_t i = 0; i < lights_.size(); ++i) {
    if (lights_[i].get() == light) return static_cast<int>(i);
  }
  return -1;
}

double SceneLights::pmf(int index) const { return any_ ? distribution_.pmf(index) : 0.0; }

}  // namespace kiln::scene
