// Light probes (issue 20): a ProbeVolume's settings, in a ProbesJob ("job.probes.volume") or in a lightmap job
// ("job.lightmap.probes"), and the probes job itself: its scene is a LightmapJob translated as the lightmap job's is,
// with every field it names moved under "job.probes.scene", and no lightmap baked.
#include <set>
#include <string>

#include "bakers/bake/number_format.h"
#include "daemon/translate_fields.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon::detail {
namespace {

using bake::format_number;

const std::string kPath = "job.probes";
const std::string kLightmapPath = "job.lightmap";
const std::string kScenePath = "job.probes.scene";

Vec3 corner(const kiln::v1::Vector3& v, const std::string& field) {
  check_range(field + ".x", v.x(), bounds::kProbeCoordinate);
  check_range(field + ".y", v.y(), bounds::kProbeCoordinate);
  check_range(field + ".z", v.z(), bounds::kProbeCoordinate);
  return {v.x(), v.y(), v.z()};
}

// A region: both corners, finite, lo below hi on every axis (a flat or inverted box holds no volume).
lightmap::ProbeBox region(const kiln::v1::MediumBox& b, const std::string& p) {
  if (!b.has_lo()) throw InvalidField(p + ".lo", "required: the region's lowest corner");
  if (!b.has_hi()) throw InvalidField(p + ".hi", "required: the region's highest corner");
  const lightmap::ProbeBox box{corner(b.lo(), p + ".lo"), corner(b.hi(), p + ".hi")};
  if (!(box.lo.x < box.hi.x && box.lo.y < box.hi.y && box.lo.z < box.hi.z)) {
    throw InvalidField(p + ".hi", "must be above lo on every axis (a region holds a volume of probes), got lo (" +
                                      format_number(box.lo.x) + ", " + format_number(box.lo.y) + ", " +
                                      format_number(box.lo.z) + "), hi (" + format_number(box.hi.x) + ", " +
                                      format_number(box.hi.y) + ", " + format_number(box.hi.z) + ")");
  }
  return box;
}

// "job.lightmap…" as the probes job names it; any other field ("job.quality…", "job") as it is.
std::string moved(const std::string& field) {
  if (field.rfind(kLightmapPath, 0) != 0) return field;
  return kScenePath + field.substr(kLightmapPath.size());
}

// The scene part of a probes job's LightmapJob: its lightmap settings cleared (no lightmap is baked, so none may
// refuse the job or weigh on its memory estimate).
kiln::v1::LightmapJob scene_only(const kiln::v1::LightmapJob& j) {
  kiln::v1::LightmapJob s = j;
  s.set_resolution(4);  // the least: the texel bound and the estimate count no lightmap anyway
  s.clear_lightmaps();
  s.clear_padding();
  s.clear_radiance();
  s.clear_ao();
  s.clear_directional();
  s.clear_preview();
  s.clear_denoise();
  s.clear_stitch_seams();
  s.clear_texel_density();
  s.clear_page_size();
  s.clear_max_pages();
  s.clear_uniform_pages();
  s.set_generate_uvs(kiln::v1::GENERATE_UVS_NEVER);  // probes need no lightmap UVs
  return s;
}

void translate_scene(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r) {
  kiln::v1::JobSpec inner;
  *inner.mutable_quality() = spec.quality();
  *inner.mutable_force_effects() = spec.force_effects();
  *inner.mutable_lightmap() = scene_only(spec.probes().scene());
  try {
    translate_lightmap(inner, blobs, r);
  } catch (const InvalidField& e) {
    const std::string problem = std::string(e.what()).substr(e.field().size() + 2);
    throw InvalidField(moved(e.field()), problem);
  }
  for (BlobRef& b : r.inputs) b.field = moved(b.field);
  LightmapMemoryBasis& basis = *r.lightmap_memory;
  basis.texel_field = moved(basis.texel_field);
  basis.scene_field = moved(basis.scene_field);
  basis.input_field = moved(basis.input_field);
}

}  // namespace

void probe_volume(const kiln::v1::ProbeVolume& v, const std::string& p, lightmap::ProbeVolumeOptions& out) {
  if (v.regions_size() > bounds::kProbeRegions.hi) {
    throw InvalidField(p + ".regions", "at most " + std::to_string(bounds::kProbeRegions.hi) + " boxes, got " +
                                           std::to_string(v.regions_size()));
  }
  for (int i = 0; i < v.regions_size(); ++i)
    out.regions.push_back(region(v.regions(i), p + ".regions[" + std::to_string(i) + "]"));
  if (v.spacing() == 0) throw InvalidField(p + ".spacing", "required: the distance between probes, in (0, 1e6]");
  check_range(p + ".spacing", v.spacing(), bounds::kProbeSpacing);
  out.spacing = v.spacing();
  if (v.has_max_distance()) {
    check_range(p + ".max_distance", v.max_distance(), bounds::kProbeMaxDistance);
    out.max_distance = v.max_distance();
  }
  if (v.has_max_probes()) {
    check_range(p + ".max_probes", static_cast<double>(v.max_probes()), bounds::kProbeCount.real());
    out.max_probes = v.max_probes();
  }
  out.preview = !v.has_preview() || v.preview();
}

void translate_probes(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r) {
  const kiln::v1::ProbesJob& job = spec.probes();
  if (!job.has_scene()) throw InvalidField(kScenePath, "required: the scene, as a lightmap job gives it");
  if (job.scene().has_probes()) {
    throw InvalidField(kScenePath + ".probes", "a probes job's settings go in job.probes.volume; leave this unset");
  }
  if (!job.has_volume()) throw InvalidField(kPath + ".volume", "required: the probes' spacing at least");
  translate_scene(spec, blobs, r);
  lightmap::LightmapBakeInput& in = r.lightmap();
  in.lightmaps = false;
  probe_volume(job.volume(), kPath + ".volume", in.probes);
  // The estimate again, of probes and no lightmap.
  LightmapMemoryBasis& basis = *r.lightmap_memory;
  basis.size.lightmap_texels.clear();
  basis.size.probes = in.probes.max_probes;
  basis.lightmaps = 0;
  basis.texels = 0;
  basis.probe_field = kPath + ".volume.max_probes";
  plan_lightmap_memory(r, in.memory_limit_bytes);
}

std::string probes_canonical_text(const lightmap::ProbeVolumeOptions& p) {
  std::string o = "probes=spacing:" + format_number(p.spacing) + ",max_distance:" + format_number(p.distance()) +
                  ",max_probes:" + std::to_string(p.max_probes) + ",preview:" + (p.preview ? "1" : "0") + ",regions:";
  for (const lightmap::ProbeBox& b : p.regions) {
    o += format_number(b.lo.x) + " " + format_number(b.lo.y) + " " + format_number(b.lo.z) + " " +
         format_number(b.hi.x) + " " + format_number(b.hi.y) + " " + format_number(b.hi.z) + ";";
  }
  return o + "\n";
}

}  // namespace kiln::daemon::detail
