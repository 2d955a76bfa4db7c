// The field translators daemon/translate.cpp is built from, shared with the lightmap job's translation
// (translate_lightmap.cpp): each checks one message against its documented bounds and throws InvalidField naming the
// offending field's path. Internal to the translation layer.
#pragma once

#include <string>

#include "bakers/brdf/material.h"
#include "bakers/math/rgb.h"
#include "daemon/translate.h"

namespace kiln::v1 {
class Brdf;
class Color;
class Digest;
class Layered;
}  // namespace kiln::v1

namespace kiln::daemon::detail {

// v in [lo, hi] (or (lo, hi] with lo_open) and finite.
void check_range(const std::string& field, double v, double lo, double hi, bool lo_open);
// Each channel in [lo, hi].
Rgb color(const kiln::v1::Color& c, const std::string& field, double lo, double hi);
// A baker's complaint about a field of its input, as that field under `prefix` in the spec.
InvalidField baker_problem(const std::string& prefix, const bake::InvalidInput& problem);
// An input blob's digest: well formed, within kMaxInputBlobBytes and, with a store, stored whole.
BlobRef input_blob(const kiln::v1::Digest& d, const std::string& field, const store::BlobStore* blobs);
// One model of the BRDF library.
brdf::ModelSpec brdf_model(const kiln::v1::Brdf& m, const std::string& path);
// A diffuse and a specular lobe; a missing specular lobe is none (a weightless one).
brdf::MaterialSpec material_spec(const kiln::v1::Layered& l, const std::string& path);

// An input blob's bytes, verified against its digest; InvalidField naming its field if the store no longer holds it.
std::string read_input(const BlobRef& ref, store::BlobStore& blobs);

// The lightmap job (translate_lightmap.cpp): translation into r.lightmap, its blobs' reading, its canonical text.
void translate_lightmap(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r);
void load_lightmap_inputs(BakeRequest& r, store::BlobStore& blobs);
std::string lightmap_canonical_text(const BakeRequest& r);
// A colour space of the active OpenColorIO config (at most 64 bytes), else InvalidField listing the known ones.
void check_color_space(const std::string& name, const std::string& field);

}  // namespace kiln::daemon::detail
