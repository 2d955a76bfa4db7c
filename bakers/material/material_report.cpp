#include "bakers/material/material_report.h"

#include <nlohmann/json.hpp>

#include <string>

namespace kiln::material {
namespace {

using Json = nlohmann::ordered_json;

Json rgb_json(const Rgb& c) { return Json::array({c.r, c.g, c.b}); }
Json vec_json(const Vec3& v) { return Json::array({v.x, v.y, v.z}); }

Json model_json(const MaterialBakeInput& input, const MaterialBakeResult& result) {
  if (!input.material) {
    const brdf::Model m = input.model.model;
    return {{"description", result.description},
            {"name", brdf::to_string(m)},
            {"roughness_parameter", brdf::roughness_name(m)}};
  }
  const brdf::MaterialSpec& mat = *input.material;
  const bool weights = mat.combine == brdf::Combine::weights;
  return {{"description", result.description},
          {"name", "material"},
          {"combine", weights ? "weights" : "layered"},
          {"specular_weight", weights ? Json(mat.specular_weight) : Json(nullptr)},
          {"diffuse", brdf::to_string(mat.diffuse.model)},
          {"specular", brdf::to_string(mat.specular.model)},
          // The split-sum rows sweep the specular lobe's roughness.
          {"roughness_parameter", brdf::roughness_name(mat.specular.model)}};
}

Json settings_json(const MaterialBakeInput& input) {
  return {{"table_mu", input.table_mu},
          {"table_roughness", input.table_roughness},
          {"merl", input.merl},
          {"samples", input.samples},
          {"target_error", input.target_error},
          {"time_limit_seconds", input.time_limit_seconds},
          {"seed", input.seed}};
}

Json average_albedo_json(const MaterialBakeResult& result) {
  return {{"value", rgb_json(result.albedo.average.value)},
          {"std_error", rgb_json(result.albedo.average.std_error)},
          {"white_furnace", result.white_furnace.average.value.max()},
          {"white_furnace_std_error", result.white_furnace.average.std_error.max()}};
}

Json energy_json(const EnergyCheck& en) {
  return {{"max_albedo", en.max_albedo},
          {"max_albedo_mu", en.max_albedo_mu},
          {"max_albedo_channel", std::string(1, "RGB"[en.max_albedo_channel])},
          {"max_albedo_std_error", en.max_albedo_error},
          {"white_furnace_max_albedo", en.white_max_albedo},
          {"white_furnace_max_albedo_mu", en.white_max_albedo_mu},
          {"white_furnace_max_albedo_std_error", en.white_max_albedo_error},
          {"conserves_energy", en.conserves_energy}};
}

Json reciprocity_json(const ReciprocityCheck& rc) {
  const bool differed = rc.max_relative_difference > 0;  // null directions: no pair differed at all
  return {{"pairs", rc.pairs},
          {"max_relative_difference", rc.max_relative_difference},
          {"worst_wo", differed ? vec_json(rc.worst_wo) : Json(nullptr)},
          {"worst_wi", differed ? vec_json(rc.worst_wi) : Json(nullptr)},
          {"model_claims_reciprocal", rc.model_claims_reciprocal}};
}

Json validation_json(const ValidationReport& v) {
  Json approximations = Json::array();
  for (const auto& a : v.approximations) {
    approximations.push_back({{"name", a.name},
                              {"max_abs_albedo_difference", a.max_abs_difference},
                              {"at_mu", a.at_mu},
                              {"mean_abs_albedo_difference", a.mean_abs_difference},
                              {"std_error_bound", a.std_error}});
  }
  return {{"energy", energy_json(v.energy)},
          {"reciprocity", reciprocity_json(v.reciprocity)},
          {"approximations", approximations}};
}

Json cost_json(const MaterialBakeResult& result, size_t entries) {
  return {{"samples", result.samples},
          {"validation_samples", result.validation_samples},
          {"seconds", result.seconds},
          {"max_error_estimate", result.max_error_estimate},
          {"min_samples_per_entry", result.min_samples_per_entry},
          {"max_samples_per_entry", result.max_samples_per_entry},
          {"entries", static_cast<uint64_t>(entries)},
          {"target_reached", result.target_reached}};
}

Json outputs_json(const std::vector<bake::BakeOutput>& outputs) {
  Json out = Json::array();
  for (const auto& o : outputs) {
    out.push_back({{"name", o.name},
                   {"media_type", o.media_type},
                   {"color_space", o.color_space},
                   {"bytes", static_cast<uint64_t>(o.bytes.size())}});
  }
  return out;
}

}  // namespace

bake::BakeOutput material_report(const MaterialBakeInput& input, const MaterialBakeResult& result, size_t entries) {
  Json report;
  report["baker"] = kMaterialBakerVersion;
  report["model"] = model_json(input, result);
  report["settings"] = settings_json(input);
  report["average_albedo"] = average_albedo_json(result);
  report["validation"] = validation_json(result.validation);
  report["cost"] = cost_json(result, entries);
  report["plan"] = result.plan;
  report["outputs"] = outputs_json(result.outputs);
  return {"report.json", "application/json", "", report.dump(2) + "\n"};
}

}  // namespace kiln::material
