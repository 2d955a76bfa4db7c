// The pieces the translation layer is built from: the field translators every job type shares (each checks one
// message against its documented bounds and throws InvalidField naming the offending field's path), and each job
// type's translation, blob reading and canonical text (translate_material.cpp, translate_environment.cpp,
// translate_lightmap.cpp). Internal to the translation layer.
#pragma once

#include <map>
#include <string>

#include "bakers/brdf/material.h"
#include "bakers/math/rgb.h"
#include "daemon/translate.h"
#include "proto/bounds.h"

namespace kiln::v1 {
class Brdf;
class Color;
class Digest;
class Layered;
class MaterialJob;
class ProbeVolume;
}  // namespace kiln::v1

namespace kiln::daemon::detail {

// The longest effect name a job may force.
inline constexpr std::size_t kMaxEffectNameBytes = 64;

// v in the range (proto/bounds.h declares the protocol's) and finite.
void check_range(const std::string& field, double v, const bounds::Range& range);
// An optional whole-number setting: when given, v in the range is stored in `out`.
void set_count(bool given, double v, const std::string& field, const bounds::WholeRange& range, int& out);
// Each channel in the range.
Rgb color(const kiln::v1::Color& c, const std::string& field, const bounds::Range& range);
// A baker's complaint about a field of its input, as that field under `prefix` in the spec.
InvalidField baker_problem(const std::string& prefix, const bake::InvalidInput& problem);
// An input blob's digest: well formed, within kMaxInputBlobBytes and, with a store, stored whole.
BlobRef input_blob(const kiln::v1::Digest& d, const std::string& field, const store::BlobStore* blobs);
// An input blob's bytes, verified against its digest; InvalidField naming its field if the store no longer holds it.
std::string read_input(const BlobRef& ref, store::BlobStore& blobs);
// A colour space of the active OpenColorIO config (at most 64 bytes), else InvalidField listing the known ones.
void check_color_space(const std::string& name, const std::string& field);
// The spec's forced effects for a baker whose planner knows their names: each name 1 to 64 bytes.
std::map<std::string, bool> forced_effects(const kiln::v1::JobSpec& spec);

// BRDF models (translate_brdf.cpp). One model of the BRDF library:
brdf::ModelSpec brdf_model(const kiln::v1::Brdf& m, const std::string& path);
// The material job's one model (its oneof is a Brdf's, plus a layered case that material_spec translates).
brdf::ModelSpec material_job_model(const kiln::v1::MaterialJob& m, const std::string& path);
// A diffuse and a specular lobe; a missing specular lobe is none (a weightless one).
brdf::MaterialSpec material_spec(const kiln::v1::Layered& l, const std::string& path);

// The material job (translate_material.cpp): translation into r.input, its canonical text.
void translate_material(const kiln::v1::JobSpec& spec, BakeRequest& r);
std::string material_canonical_text(const BakeRequest& r);

// The environment job (translate_environment.cpp): translation into r.input, its blobs' reading, its canonical text.
void translate_environment(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r);
void load_environment_inputs(BakeRequest& r, store::BlobStore& blobs);
std::string environment_canonical_text(const BakeRequest& r);

// The lightmap job (translate_lightmap.cpp): translation into r.input, its blobs' reading, its canonical text.
void translate_lightmap(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r);
void load_lightmap_inputs(BakeRequest& r, store::BlobStore& blobs);
std::string lightmap_canonical_text(const BakeRequest& r);
// The lightmap job's estimate and tiles under `limit` (0: none), from r.lightmap_memory.
void plan_lightmap_memory(BakeRequest& r, uint64_t limit);
// The VDB media's part of that estimate, from their files' structure (size_vdb_media), planned again.
void size_lightmap_vdb_media(BakeRequest& r, store::BlobStore& blobs);

// Light probes (translate_probes.cpp): a ProbeVolume's settings at path `p`; the probes job into r.input (a lightmap
// input that bakes no lightmap; its canonical text is the lightmap job's); the probes' line of a canonical text.
void probe_volume(const kiln::v1::ProbeVolume& v, const std::string& p, lightmap::ProbeVolumeOptions& out);
void translate_probes(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r);
std::string probes_canonical_text(const lightmap::ProbeVolumeOptions& p);

}  // namespace kiln::daemon::detail
