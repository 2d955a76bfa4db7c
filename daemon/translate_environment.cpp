// The environment job's part of the translation layer: a kiln.v1.EnvironmentJob in, an
// envmap::EnvironmentBakeInput out. The image or faces are named by digest here and read by the worker.
#include <sstream>

#include "bakers/bake/number_format.h"
#include "daemon/translate_fields.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon::detail {
namespace {

using bake::format_number;
using EJ = kiln::v1::EnvironmentJob;

const std::string kPath = "job.environment";

// Every level down to 4x4: the baker's default and its largest count.
int most_levels(int size) {
  int levels = 1;
  while ((size >> levels) >= 4) ++levels;
  return levels;
}

// An uploaded image, six uploaded faces (their digests into r.inputs) or a constant colour.
void environment_source(const EJ& e, const store::BlobStore* blobs, BakeRequest& r, envmap::EnvironmentBakeInput& in) {
  switch (e.source_case()) {
    case EJ::kImage:
      r.inputs.push_back(input_blob(e.image(), kPath + ".image", blobs));
      break;
    case EJ::kFaces: {
      const int n = e.faces().digests_size();
      if (n != 6) {
        throw InvalidField(kPath + ".faces.digests",
                           "exactly six faces (+X, -X, +Y, -Y, +Z, -Z), got " + std::to_string(n));
      }
      for (int i = 0; i < n; ++i) {
        r.inputs.push_back(
            input_blob(e.faces().digests(i), kPath + ".faces.digests[" + std::to_string(i) + "]", blobs));
      }
      break;
    }
    case EJ::kConstant:
      in.constant = color(e.constant(), kPath + ".constant", bounds::kEnvironmentConstant);
      break;
    case EJ::SOURCE_NOT_SET:
      throw InvalidField(kPath,
                         "no environment given: set image (an uploaded equirectangular image), faces (six "
                         "uploaded cube faces) or constant (a colour)");
  }
}

// How the image or faces decode; a constant colour has nothing to decode.
void decode_options(const EJ& e, envmap::EnvironmentBakeInput& in) {
  const bool constant = e.source_case() == EJ::kConstant;
  auto image_only = [&](const char* name) {
    throw InvalidField(kPath + "." + name,
                       "applies to an image or faces; a constant colour is already radiance in "
                       "the working space: leave it out");
  };
  if (!e.color_space().empty()) {
    if (constant) image_only("color_space");
    check_color_space(e.color_space(), kPath + ".color_space");
    in.decode.color_space = e.color_space();
  }
  if (e.has_rotation_degrees()) {
    if (constant) image_only("rotation_degrees");
    check_range(kPath + ".rotation_degrees", e.rotation_degrees(), bounds::kRotationDegrees);
    in.decode.rotation_degrees = e.rotation_degrees();
  }
  if (e.has_intensity()) {
    if (constant) image_only("intensity");
    check_range(kPath + ".intensity", e.intensity(), bounds::kEnvironmentIntensity);
    in.decode.intensity = e.intensity();
  }
}

// The outputs: the specular cube's lobe, size and levels, the irradiance cube, the DFG table, the preview.
void cube_settings(const EJ& e, envmap::EnvironmentBakeInput& in) {
  switch (e.lobe()) {
    case kiln::v1::ENVIRONMENT_LOBE_DEFAULT:
    case kiln::v1::ENVIRONMENT_LOBE_GGX:
      in.lobe = envmap::EnvLobe::ggx;
      break;
    case kiln::v1::ENVIRONMENT_LOBE_BECKMANN:
      in.lobe = envmap::EnvLobe::beckmann;
      break;
    case kiln::v1::ENVIRONMENT_LOBE_COOK_TORRANCE:
      in.lobe = envmap::EnvLobe::cook_torrance;
      break;
    case kiln::v1::ENVIRONMENT_LOBE_SCHLICK:
      in.lobe = envmap::EnvLobe::schlick;
      break;
    default:
      throw InvalidField(kPath + ".lobe", "unknown value " + std::to_string(static_cast<int>(e.lobe())));
  }
  if (e.has_size()) {
    const uint32_t n = e.size();
    if (n < 4 || n > 2048 || (n & (n - 1)) != 0) {
      throw InvalidField(kPath + ".size", "must be a power of two in [4, 2048], got " + std::to_string(n));
    }
    in.size = static_cast<int>(n);
  }
  set_count(e.has_levels(), e.levels(), kPath + ".levels", bounds::WholeRange{bounds::kLevels.lo, most_levels(in.size)},
            in.levels);
  set_count(e.has_irradiance_size(), e.irradiance_size(), kPath + ".irradiance_size", bounds::kIrradianceSize,
            in.irradiance_size);
  set_count(e.has_dfg_size(), e.dfg_size(), kPath + ".dfg_size", bounds::kDfgSize, in.dfg_size);
  set_count(e.has_dfg_samples(), e.dfg_samples(), kPath + ".dfg_samples", bounds::kDfgSamples, in.dfg_samples);
  if (e.has_preview()) in.preview = e.preview();
  switch (e.dfg_masking()) {
    case kiln::v1::MASKING_DEFAULT:
      break;
    case kiln::v1::MASKING_SEPARABLE:
      in.dfg_masking = brdf::Masking::separable;
      break;
    case kiln::v1::MASKING_HEIGHT_CORRELATED:
      in.dfg_masking = brdf::Masking::height_correlated;
      break;
    case kiln::v1::MASKING_V_GROOVE:
      in.dfg_masking = brdf::Masking::v_groove;
      break;
    case kiln::v1::MASKING_SCHLICK:
      in.dfg_masking = brdf::Masking::schlick;
      break;
    default:
      throw InvalidField(kPath + ".dfg_masking", "unknown value " + std::to_string(e.dfg_masking()));
  }
}

void environment_quality(const kiln::v1::Quality& q, envmap::EnvironmentBakeInput& in) {
  if (q.has_samples()) {
    check_range("job.quality.samples", static_cast<double>(q.samples()), bounds::kEnvironmentSamples.real());
    in.samples = static_cast<int>(q.samples());
  }
  if (q.has_target_error()) {
    check_range("job.quality.target_error", q.target_error(), bounds::kEnvironmentTargetError);
    in.target_error = q.target_error();
  }
  if (q.has_time_limit_seconds()) {
    throw InvalidField("job.quality.time_limit_seconds",
                       "not supported by the environment bake; bound its cost "
                       "with samples or target_error");
  }
  in.seed = q.seed();
}

// The baker's own validation is the backstop (and knows the effects its planner decides). The bytes are not read
// yet: stand-ins show it the source's shape, which is all it checks before decoding.
void validate_environment(const EJ& e, const BakeRequest& r, const envmap::EnvironmentBakeInput& in) {
  envmap::EnvironmentBakeInput probe = in;
  if (e.source_case() == EJ::kImage) probe.image = "(uploaded image)";
  if (e.source_case() == EJ::kFaces) probe.faces.assign(r.inputs.size(), "(uploaded face)");
  if (auto problem = envmap::validate(probe)) {
    // Forced effects, sources and samples live elsewhere in the spec than in the baker's input.
    const std::string& field = problem->field();
    if (field.rfind("force_effects", 0) == 0) throw baker_problem("job", *problem);
    if (field == "samples" || field == "target_error" || field == "seed") throw baker_problem("job.quality", *problem);
    if (field == "image" && !r.inputs.empty()) throw InvalidField(r.inputs[0].field, problem->problem());
    throw baker_problem(kPath, *problem);
  }
}

}  // namespace

void translate_environment(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r) {
  const EJ& e = spec.environment();
  envmap::EnvironmentBakeInput& in = r.input.emplace<envmap::EnvironmentBakeInput>();
  environment_source(e, blobs, r, in);
  decode_options(e, in);
  cube_settings(e, in);
  environment_quality(spec.quality(), in);
  in.force_effects = forced_effects(spec);
  validate_environment(e, r, in);
  uint64_t encoded = 0;
  for (const BlobRef& b : r.inputs) encoded += b.size;
  const bool faces = r.inputs.size() > 1;
  r.memory_bytes = envmap::estimate_environment_job_memory(in, encoded, faces);
  r.memory_field = in.constant ? "job.environment.size" : faces ? "job.environment.faces" : "job.environment.image";
  r.memory_note = "a " + std::to_string(in.size) + "^2 cube chain from " +
                  (in.constant ? std::string("a constant") : std::to_string(encoded) + " encoded bytes");
}

void load_environment_inputs(BakeRequest& r, store::BlobStore& blobs) {
  envmap::EnvironmentBakeInput& in = r.environment();
  in.image.clear();
  in.faces.clear();
  for (const BlobRef& ref : r.inputs) {
    std::string bytes = read_input(ref, blobs);
    if (ref.field.find(".faces.") != std::string::npos) {
      in.faces.push_back(std::move(bytes));
    } else {
      in.image = std::move(bytes);
    }
  }
}

// The environment bake's settings, defaults applied; its input blobs by digest (their bytes are named by it).
std::string environment_canonical_text(const BakeRequest& r) {
  const envmap::EnvironmentBakeInput& in = r.environment();
  std::ostringstream o;
  o << "type=" << job_type(r) << "\nsource=";
  if (in.constant) {
    o << "constant:" << format_number(in.constant->r) << "," << format_number(in.constant->g) << ","
      << format_number(in.constant->b);
  } else {
    o << (r.inputs.size() == 1 ? "image" : "faces");
    for (const BlobRef& b : r.inputs) o << ":" << b.sha256 << "/" << b.size;
  }
  // An empty colour space is the format's default, which the same bytes always decode to.
  o << "\ncolor_space=" << (in.decode.color_space.empty() ? "(format default)" : in.decode.color_space)
    << "\nrotation_degrees=" << format_number(in.decode.rotation_degrees)
    << "\nintensity=" << format_number(in.decode.intensity) << "\nlobe=" << envmap::to_string(in.lobe)
    << "\nsize=" << in.size << "\nlevels=" << (in.levels != 0 ? in.levels : most_levels(in.size))
    << "\nirradiance_size=" << in.irradiance_size << "\ndfg_size=" << in.dfg_size << "\ndfg_samples=" << in.dfg_samples
    << "\ndfg_masking=" << brdf::to_string(envmap::dfg_masking(in.lobe, in.dfg_masking)) << "\nsamples=" << in.samples
    << "\ntarget_error=" << format_number(in.target_error) << "\npreview=" << in.preview << "\nseed=" << in.seed
    << "\nforce_effects=";
  for (const auto& [effect, on] : in.force_effects) o << effect << (on ? "+" : "-") << ";";  // sorted by name
  o << "\n";
  return o.str();
}

}  // namespace kiln::daemon::detail
