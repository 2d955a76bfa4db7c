// The one translation layer between the wire and the bakers: a kiln.v1 JobSpec in, plain bakers types out, with
// every field validated and bounded. A bad field is reported with its path from the Submit body
// ("job.material.ggx.alpha: must be in (0, 1], got -0.2"). The generated protobuf header stays out of this one.
#pragma once

#include <stdexcept>
#include <optional>
#include <string>

#include <cstdint>
#include <variant>
#include <vector>

#include "bakers/envmap/environment_bake.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/memory_estimate.h"
#include "bakers/material/material_bake.h"

namespace kiln::v1 {
class JobSpec;
}
namespace kiln::store {
class BlobStore;
}

namespace kiln::daemon {

// A field of a job spec is missing, out of range or malformed.
class InvalidField : public std::invalid_argument {
 public:
  InvalidField(std::string field, const std::string& problem)
      : std::invalid_argument(field + ": " + problem), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

// An uploaded blob a job reads, and the field that names it ("job.environment.faces.digests[2]").
struct BlobRef {
  std::string field;
  std::string sha256;
  uint64_t size = 0;
};

// The largest input blob a job may refer to (an environment image or face): decoding needs it whole in memory.
inline constexpr uint64_t kMaxInputBlobBytes = uint64_t{512} << 20;

// What a lightmap job's memory estimate is made of (bakers/lightmap/memory_estimate.h), and the fields a refusal
// names for each part.
struct LightmapMemoryBasis {
  lightmap::LightmapJobSize size;
  std::string texel_field, scene_field, input_field;
  std::string probe_field;  // when the job bakes probes: their max_probes
  std::vector<std::string> vdb_media_fields;  // the file field of each of size.vdb_media ("...media[2].vdb.file")
  size_t lightmaps = 0;  // lightmaps, or atlas pages when `pages`
  bool pages = false;
  uint64_t texels = 0;
};

// The bake a job spec asks for: the input of one of the three bakers.
struct BakeRequest {
  std::string name;  // the spec's name, for people
  // An environment input's image or faces are empty until load_inputs reads them from the store. A lightmap input's
  // meshes' geometry, textures' bytes and environment image are empty until load_inputs decodes the mesh blobs and
  // reads the rest from the store (the baker decodes images).
  std::variant<kiln::material::MaterialBakeInput, envmap::EnvironmentBakeInput, kiln::lightmap::LightmapBakeInput>
      input;
  // Lightmap jobs: SHA-256 of the deterministic serialization of the job's scene part (meshes, instances, materials
  // after overrides, textures, lights, environment source), part of the cache key with the settings' canonical text.
  std::string scene_hash;
  std::vector<BlobRef> inputs;  // the blobs the job reads, in the order of its fields
  // What the bake will hold at its peak, estimated from the spec by the baker's own model (before anything is
  // decoded; a lightmap's VDB media from their files' structure once size_vdb_media has read it); the field whose value
  // drives the estimate most, which a refusal names; and what the estimate is made of, for people.
  uint64_t memory_bytes = 0;
  std::string memory_field;
  std::string memory_note;
  // Lightmap jobs: what their estimate is made from, to plan it again under kilnd's limit (fit_memory_limit).
  std::optional<LightmapMemoryBasis> lightmap_memory;

  // The input, for a request known to hold that type (std::bad_variant_access otherwise).
  kiln::material::MaterialBakeInput& material() { return std::get<kiln::material::MaterialBakeInput>(input); }
  const kiln::material::MaterialBakeInput& material() const {
    return std::get<kiln::material::MaterialBakeInput>(input);
  }
  envmap::EnvironmentBakeInput& environment() { return std::get<envmap::EnvironmentBakeInput>(input); }
  const envmap::EnvironmentBakeInput& environment() const { return std::get<envmap::EnvironmentBakeInput>(input); }
  kiln::lightmap::LightmapBakeInput& lightmap() { return std::get<kiln::lightmap::LightmapBakeInput>(input); }
  const kiln::lightmap::LightmapBakeInput& lightmap() const {
    return std::get<kiln::lightmap::LightmapBakeInput>(input);
  }
};

// The job type of a request as the protocol and the job database spell it: "material", "environment", "lightmap"
// or "probes" (a lightmap input that bakes no lightmap). It is also the spec's field that holds the job
// ("job.material").
const char* job_type(const BakeRequest& request);

// Validates the whole spec and translates it. Throws InvalidField. With `blobs`, the input blobs the spec names
// must be stored whole there (else InvalidField naming the digest's field); without, only their form is checked.
BakeRequest translate(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs = nullptr);

// The most bytes of input blobs one job may refer to in all (a lightmap job's meshes, textures and environment).
inline constexpr uint64_t kMaxJobInputBytes = uint64_t{4} << 30;

// Reads the request's input blobs from the store into its input (environment.image or environment.faces; a
// lightmap job's mesh blobs decoded into its scene, textures and environment image as encoded bytes).
// Throws InvalidField if one is no longer stored or a mesh blob does not decode, store::StoreError if one fails
// verification.
void load_inputs(BakeRequest& request, store::BlobStore& blobs);

// A bake's complaint about its input, as the field of the job at fault. A bake::InvalidInput is mapped by its
// field alone: under "job.<type>", except the lightmap bake's "textures[I]" and "environment_image" (bytes that do
// not decode), which become the field of that blob. Any other error is about bytes that do not decode: the image
// (or "job.environment.faces") of an environment job, the whole job for a lightmap. The message is the baker's.
InvalidField input_error(const BakeRequest& request, const std::exception& e);

// The version of the baker that runs `request`, for its cache key and report.
const char* baker_version(const BakeRequest& request);

// The canonical text of a translated request: every setting, defaults applied, numbers in round-trip precision,
// the name left out. Two specs that ask for the same bake have the same text.
std::string canonical_text(const BakeRequest& request);

// Reads the structure of a lightmap job's VDB media files from the store (lightmap::vdb_medium_size: nothing of
// OpenVDB allocated) into its memory estimate, which the spec alone cannot give. Call it after translate() and
// before fit_memory_limit(); other jobs are left as they are. Throws InvalidField naming the medium's vdb.file for a
// file that is not a VDB file kiln reads or lacks a named grid, or is no longer stored; store::StoreError if one
// fails verification.
void size_vdb_media(BakeRequest& request, store::BlobStore& blobs);

// Plans the request's memory under kilnd's limit: a lightmap job bakes under the smaller of its own
// memory_limit_bytes and `server_limit`, untiled when its estimate fits that and in tiles otherwise
// (lightmap::plan_memory), which sets its input's tile size and the request's estimate. Call it after translate() and
// before cache_key() (the tile size is part of the key). Other jobs are left as they are.
void fit_memory_limit(BakeRequest& request, uint64_t server_limit);

// Lets the bakers keep the tables they may share between jobs and processes (an environment bake's DFG tables) in
// `folder` (under the store), besides in the process.
void keep_baker_tables_in(const std::string& folder);

// The result-cache key: SHA-256 of the canonical text and the baker version.
std::string cache_key(const BakeRequest& request, const std::string& baker_version);

// The version of the material baker's numerics (baker_version gives each job's); part of every cache key, so a
// new version never serves old results.
extern const char* const kBakerVersion;

}  // namespace kiln::daemon
