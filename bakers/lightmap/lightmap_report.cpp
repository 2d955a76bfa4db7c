#include "bakers/lightmap/lightmap_report.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "bakers/bake/number_format.h"

namespace kiln::lightmap {
namespace {

using bake::format_number;

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string lightmap_json(const LightmapReportEntry& m) {
  std::ostringstream o;
  o << "{\"name\": " << json_string(m.name) << ", \"resolution\": " << m.resolution
    << ", \"valid_texels\": " << m.error.valid << ", \"samples_per_texel_point\": "
    << format_number(m.memory.samples_per_valid_texel) << ", \"error_rms\": " << format_number(m.error.rms)
    << ", \"error_max\": " << format_number(m.error.max) << ", \"above_target\": " << m.error.above_target;
  if (m.sh) {
    o << ", \"sh_error_rms\": " << format_number(m.sh->rms) << ", \"sh_error_max\": " << format_number(m.sh->max);
  }
  o << ", \"leaks\": {\"moved\": " << m.leaks.moved << ", \"invalidated\": " << m.leaks.invalidated
    << ", \"texels_invalidated\": " << m.leaks.texels_invalidated << "}, \"memory_bytes\": " << m.memory.total_bytes
    << ", \"memory\": " << json_string(m.memory.describe()) << "}";
  return o.str();
}

}  // namespace

std::string report_json(const LightmapBakeResult& result, const LightmapReport& report) {
  const plan::LightmapPlan& plan = *report.plan;
  std::ostringstream json;
  json << "{\n  \"baker\": \"" << kLightmapBakerVersion << "\",\n  \"seconds\": " << format_number(result.seconds)
       << ",\n  \"samples\": " << result.samples << ",\n  \"rays\": " << result.rays
       << ",\n  \"occlusion_rays\": " << result.occlusion_rays
       << ",\n  \"general_bsdf_vertices\": " << result.general_vertices
       << ",\n  \"mrays_per_second\": " << format_number(result.rays / std::max(result.seconds, 1e-9) / 1e6)
       << ",\n  \"target_error\": " << format_number(report.target_error)
       << ",\n  \"error_estimate\": " << format_number(result.error_estimate)
       << ",\n  \"dropped_samples\": " << report.dropped_samples
       << ",\n  \"color_space\": " << json_string(report.color_space)
       << ",\n  \"units\": \"irradiance W/m^2\",\n  \"plan\": [";
  for (size_t i = 0; i < plan.decisions.size(); ++i) {
    const plan::Decision& d = plan.decisions[i];
    json << (i ? "," : "") << "\n    {\"effect\": " << json_string(d.effect) << ", \"enabled\": "
         << (d.enabled ? "true" : "false") << ", \"forced\": " << (d.forced ? "true" : "false")
         << ", \"reason\": " << json_string(d.reason) << "}";
  }
  json << "\n  ],\n  \"bounces\": " << plan.bounces << ",\n  \"albedo_max\": " << format_number(plan.albedo_max)
       << ",\n  \"curve\": [";
  for (size_t i = 0; i < result.curve.size(); ++i) {
    json << (i ? ", " : "") << "{\"seconds\": " << format_number(result.curve[i].seconds) << ", \"samples\": "
         << result.curve[i].samples << ", \"error\": " << format_number(result.curve[i].error) << "}";
  }
  json << "],\n  \"lightmaps\": [\n    ";
  for (size_t i = 0; i < report.lightmaps.size(); ++i) {
    json << (i ? ",\n    " : "") << lightmap_json(report.lightmaps[i]);
  }
  json << "\n  ],\n  \"tracer\": {\"triangles\": " << report.tracer_triangles << ", \"memory_bytes\": "
       << report.tracer_bytes << ", \"bytes_per_triangle\": "
       << format_number(report.tracer_triangles ? static_cast<double>(report.tracer_bytes) / report.tracer_triangles
                                                : 0.0)
       << "},\n  \"scene_problems\": {\"total\": " << report.scene_problems << ", \"listed\": [";
  for (size_t i = 0; i < result.skipped.size(); ++i) json << (i ? ", " : "") << json_string(result.skipped[i]);
  json << "]}\n}\n";
  return json.str();
}

}  // namespace kiln::lightmap
