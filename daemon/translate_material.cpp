// The material job's part of the translation layer: a kiln.v1.MaterialJob in, a material::MaterialBakeInput out.
#include <sstream>

#include "bakers/bake/number_format.h"
#include "daemon/translate_fields.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon::detail {
namespace {

using bake::format_number;

// The material bake has one optional effect: the MERL table. Forcing it overrides `merl`.
void material_effects(const kiln::v1::JobSpec& spec, material::MaterialBakeInput& in) {
  for (const auto& [effect, on] : spec.force_effects()) {
    const std::string field = "job.force_effects[" + effect.substr(0, kMaxEffectNameBytes) + "]";
    if (effect.size() > kMaxEffectNameBytes) throw InvalidField(field, "effect names are at most 64 bytes");
    if (effect != "merl") throw InvalidField(field, "unknown effect for a material bake; known: merl");
    in.merl = on;
  }
}

void material_quality(const kiln::v1::Quality& q, material::MaterialBakeInput& in) {
  if (q.has_samples()) {
    check_range("job.quality.samples", static_cast<double>(q.samples()), bounds::kMaterialSamples.real());
    in.samples = q.samples();
  }
  if (q.has_target_error()) {
    check_range("job.quality.target_error", q.target_error(), bounds::kMaterialTargetError);
    in.target_error = q.target_error();
  }
  if (q.has_time_limit_seconds()) {
    check_range("job.quality.time_limit_seconds", q.time_limit_seconds(), bounds::kMaterialTimeLimitSeconds);
    in.time_limit_seconds = q.time_limit_seconds();
  }
  in.seed = q.seed();
}

// Every parameter of one model, each line starting with `prefix` (a two-lobe material's "diffuse." and "specular.").
void model_text(std::ostringstream& o, const std::string& prefix, const brdf::ModelSpec& s) {
  auto rgb = [](const Rgb& c) { return format_number(c.r) + "," + format_number(c.g) + "," + format_number(c.b); };
  auto layer = [&](const brdf::SchlickLayer& l) {
    return rgb(l.c) + "," + format_number(l.r) + "," + format_number(l.p);
  };
  o << prefix << "model=" << brdf::to_string(s.model) << "\n"
    << prefix << "albedo=" << rgb(s.albedo) << "\n"
    << prefix << "sigma=" << format_number(s.sigma) << "\n"
    << prefix << "interreflection=" << s.interreflection << "\n"
    << prefix << "alpha_x=" << format_number(s.alpha_x) << "\n"
    << prefix << "alpha_y=" << format_number(s.alpha_y) << "\n"
    << prefix << "fresnel=" << brdf::to_string(brdf::fresnel_mode(s)) << "\n"
    << prefix << "f0=" << rgb(s.f0) << "\n"
    << prefix << "eta=" << format_number(s.eta) << "\n"
    << prefix << "distribution=" << (s.distribution ? brdf::to_string(*s.distribution) : "default") << "\n"
    << prefix << "masking=" << (s.masking ? brdf::to_string(*s.masking) : "default") << "\n"
    << prefix << "normalization=" << brdf::to_string(s.normalization) << "\n"
    << prefix << "layer=" << layer(s.layer) << "\n"
    << prefix << "bottom=" << layer(s.bottom_layer) << "\n";
}

}  // namespace

void translate_material(const kiln::v1::JobSpec& spec, BakeRequest& r) {
  const kiln::v1::MaterialJob& m = spec.material();
  material::MaterialBakeInput& in = r.input.emplace<material::MaterialBakeInput>();
  if (m.model_case() == kiln::v1::MaterialJob::kLayered) {
    in.material = material_spec(m.layered(), "job.material.layered");
  } else {
    in.model = material_job_model(m, "job.material");
  }
  set_count(m.has_table_mu(), m.table_mu(), "job.material.table_mu", bounds::kTableSize, in.table_mu);
  set_count(m.has_table_roughness(), m.table_roughness(), "job.material.table_roughness", bounds::kTableSize,
            in.table_roughness);
  in.merl = m.merl();
  in.preview = !m.has_preview() || m.preview();
  material_effects(spec, in);
  material_quality(spec.quality(), in);
  if (auto problem = material::validate(in)) throw baker_problem("job.material", *problem);
  r.memory_bytes = material::estimate_material_memory(in);
  r.memory_field = in.merl ? "job.material.merl" : "job.material.table_mu";
  r.memory_note = "tables of " + std::to_string(in.table_mu) + " x " + std::to_string(in.table_roughness) +
                  (in.merl ? " entries and a MERL table" : " entries");
}

std::string material_canonical_text(const BakeRequest& r) {
  const material::MaterialBakeInput& in = r.material();
  std::ostringstream o;
  o << "type=" << job_type(r) << "\n";
  if (in.material) {
    const brdf::MaterialSpec& m = *in.material;
    o << "combine=" << (m.combine == brdf::Combine::weights ? "weights" : "layered")
      << "\nspecular_weight=" << format_number(m.specular_weight) << "\n";
    model_text(o, "diffuse.", m.diffuse);
    model_text(o, "specular.", m.specular);
  } else {
    model_text(o, "", in.model);
  }
  o << "table_mu=" << in.table_mu << "\ntable_roughness=" << in.table_roughness << "\nmerl=" << in.merl
    << "\npreview=" << in.preview << "\nsamples=" << in.samples << "\ntarget_error=" << format_number(in.target_error)
    << "\ntime_limit_seconds=" << format_number(in.time_limit_seconds) << "\nseed=" << in.seed << "\n";
  return o.str();
}

}  // namespace kiln::daemon::detail
