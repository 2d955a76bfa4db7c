#include "bakers/envmap/environment_report.h"

#include <nlohmann/json.hpp>

#include <string>

#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {
namespace {

// Insertion order is the report's key order. nlohmann writes a non-finite double as null.
using Json = nlohmann::ordered_json;

Json level_json(int k, const EnvironmentLevelReport& l) {
  return Json{{"level", k},
              {"size", l.size},
              {"roughness", l.roughness},
              {"samples", l.samples},
              {"error_estimate", l.error_estimate},
              {"noise_estimate", l.noise_estimate},
              {"checked_error", l.checked_error},
              {"seconds", l.seconds}};
}

Json plan_json(const EnvironmentPlanEntry& e) {
  return Json{{"effect", e.effect}, {"enabled", e.enabled}, {"forced", e.forced}, {"reason", e.reason}};
}

Json samples_json(const EnvironmentBakeInput& in, const EnvironmentBakeResult& r) {
  return Json{{"total", r.samples}, {"per_level", r.level_samples}, {"dfg_per_entry", in.dfg_samples}};
}

Json time_json(const EnvironmentBakeResult& r) {
  Json stages = Json::object();
  for (const auto& [stage, seconds] : r.stage_seconds) stages[stage] = seconds;
  return Json{{"total_seconds", r.seconds}, {"stages", std::move(stages)}};
}

}  // namespace

std::string environment_report_json(const EnvironmentBakeInput& in, const EnvironmentBakeResult& r,
                                    const std::string& color_space) {
  Json j;
  j["baker"] = kEnvironmentBakerVersion;
  j["size"] = in.size;
  j["lobe"] = to_string(in.lobe);
  j["dfg_masking"] = brdf::to_string(dfg_masking(in.lobe, in.dfg_masking));
  j["dfg_table"] = r.dfg_table;
  j["roughness_mapping"] = "rho_k = k/(levels-1), alpha = rho^2 (Schlick's rational Beckmann: m = rho^2)";
  j["target_error"] = in.target_error;
  j["seed"] = in.seed;
  Json levels = Json::array();
  for (size_t k = 0; k < r.levels.size(); ++k) levels.push_back(level_json(static_cast<int>(k), r.levels[k]));
  j["levels"] = std::move(levels);
  j["samples"] = samples_json(in, r);
  j["time"] = time_json(r);
  Json plan = Json::array();
  for (const EnvironmentPlanEntry& e : r.plan_entries) plan.push_back(plan_json(e));
  j["plan"] = std::move(plan);
  j["sun"] = {{"found", r.sun_found}, {"texels", r.sun_texels}, {"power_fraction", r.sun_power_fraction}};
  j["conventions"] = {
      {"up", "+Y"}, {"cubemap", std::string(kCubemapConvention)}, {"equirect", std::string(kEquirectConvention)}};
  j["color_space"] = color_space;
  j["memory"] = {{"estimated_peak_bytes", r.memory_bytes}, {"bound_bytes", kMaxEnvironmentMemory}};
  j["sanitized"] = {{"nan", r.sanitized.nan}, {"inf", r.sanitized.inf}, {"negative", r.sanitized.negative}};
  // Bytes that are not UTF-8 (none of kiln's own strings) are replaced rather than thrown on mid-bake.
  return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace kiln::envmap
