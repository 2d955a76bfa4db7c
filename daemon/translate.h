// The one translation layer between the wire and the bakers: a kiln.v1 JobSpec in, plain bakers types out, with
// every field validated and bounded. A bad field is reported with its path from the Submit body
// ("job.material.ggx.alpha: must be in (0, 1], got -0.2"). The generated protobuf header stays out of this one.
#pragma once

#include <stdexcept>
#include <string>

#include "bakers/material/material_bake.h"

namespace kiln::v1 {
class JobSpec;
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

// The bake a job spec asks for. Only the material bake exists so far; later bakers add their inputs here.
struct BakeRequest {
  std::string type;  // "material"
  std::string name;  // the spec's name, for people
  material::MaterialBakeInput material;
};

// Validates the whole spec and translates it. Throws InvalidField.
BakeRequest translate(const kiln::v1::JobSpec& spec);

// The canonical text of a translated request: every setting, defaults applied, numbers in round-trip precision,
// the name left out. Two specs that ask for the same bake have the same text.
std::string canonical_text(const BakeRequest& request);

// The result-cache key: SHA-256 of the canonical text and the baker version.
std::string cache_key(const BakeRequest& request, const std::string& baker_version);

// The version of the bakers' numerics; part of every cache key, so a new version never serves old results.
extern const char* const kBakerVersion;

}  // namespace kiln::daemon
