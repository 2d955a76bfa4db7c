// The lights of a scene and the choice of one light per next-event estimate.
//
// SceneLights owns every light the scene has: its explicit lights (point, spot, directional/sun, rect, disk), one
// EmissiveTriangles container for all emissive mesh triangles, and the environment. Each is either *sampled* (next
// -event estimation chooses it with pmf > 0) or only *evaluated* (the plan turned its strategy off: its Le is still
// what a BSDF ray that reaches it sees, with MIS weight 1 because pmf = 0).
//
// The choice is by power (luminance of Light::power, the default: pbrt-v4's PowerLightSampler) or uniform. Lights of
// zero power are never chosen; if every sampled light has zero power, sample() returns nullopt (there is no light).
// For MIS, the density of light sampling a direction that reaches light L is pmf(L) · L.pdf_li(…).
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "bakers/scene/alias_table.h"
#include "bakers/scene/emissive_triangles.h"
#include "bakers/scene/environment_light.h"
#include "bakers/scene/lights.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

enum class LightChoice { power, uniform };

// Which kinds of light next-event estimation samples (the plan's decisions; all on by default).
struct LightSamplingOptions {
  LightChoice choice = LightChoice::power;
  bool point_lights = true, spot_lights = true, directional_lights = true, area_lights = true;
  bool emissive_triangles = true;
  bool environment = true;
  bool environment_importance_map = true;  // off: the environment is sampled like a constant (cosine about n)
};

// The radius of a sphere about the centre of the scene's world-space bounding box that holds every instanced vertex
// and every finite light's position; 1 for an empty scene (so that power() of infinite lights stays meaningful).
double scene_bounding_radius(const Scene& scene);
// The world-space box of every instanced vertex and every finite light's position (lo, hi); false for an empty scene.
bool scene_box(const Scene& scene, Vec3& lo, Vec3& hi);

// Builds the light source of one scene light (the conventions of scene.h); never null.
std::unique_ptr<LightSource> make_light(const Light& light);

class SceneLights {
 public:
  SceneLights(const Scene& scene, const LightSamplingOptions& options = {});
  // For tests and hand-built scenes: these lights, all sampled.
  SceneLights(std::vector<std::unique_ptr<LightSource>> lights, double scene_radius, LightChoice choice);

  int size() const { return static_cast<int>(lights_.size()); }
  const LightSource& light(int i) const { return *lights_[i]; }
  // The emissive triangles and the environment of a scene-built SceneLights (null when the scene has none).
  const EmissiveTriangles* emissive() const { return emissive_; }
  const EnvironmentLight* environment() const { return environment_; }
  // Indices of the infinite lights (environment and directional lights with a disc: what an escaping ray sees).
  const std::vector<int>& escape_lights() const { return escape_; }
  int index_of(const LightSource* light) const;  // −1 if not one of these

  struct Choice {
    int index = -1;
    const LightSource* light = nullptr;
    double pmf = 0;
    double u_remapped = 0;  // the part of u not spent on the choice, uniform in [0, 1); u itself when single()
  };
  // One light is sampled, so sample() spends none of u on the choice.
  bool single() const { return single_ >= 0; }
  std::optional<Choice> sample(double u) const {
    if (!any_) return std::nullopt;
    if (single_ >= 0) return Choice{single_, lights_[single_].get(), 1.0, u};
    const AliasTable::Choice d = distribution_.sample(u);
    return Choice{d.index, lights_[d.index].get(), d.pmf, d.u_remapped};
  }
  double pmf(int index) const;  // 0 for lights that are not sampled
  double pmf(const LightSource* light) const { return pmf(index_of(light)); }
  double scene_radius() const { return radius_; }

 private:
  void build_distribution(const std::vector<bool>& sampled, LightChoice choice);
  std::vector<std::unique_ptr<LightSource>> lights_;
  std::vector<int> escape_;
  const EmissiveTriangles* emissive_ = nullptr;
  const EnvironmentLight* environment_ = nullptr;
  AliasTable distribution_;
  int single_ = -1;  // the only light with a non-zero choice probability, or −1
  bool any_ = false;
  double radius_ = 1;
};

}  // namespace kiln::scene
