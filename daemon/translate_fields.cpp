// The field translators every job type shares: ranges, colours, input blobs, colour spaces, forced effects.
#include "daemon/translate_fields.h"

#include "bakers/bake/range_check.h"
#include "bakers/image/color.h"
#include "daemon/store/blob_store.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon::detail {
namespace {

constexpr std::size_t kMaxColorSpaceBytes = 64;

}  // namespace

void check_range(const std::string& field, double v, const bounds::Range& range) {
  if (auto problem = bake::check_range(field, v, range)) throw InvalidField(field, problem->problem());
}

void set_count(bool given, double v, const std::string& field, const bounds::WholeRange& range, int& out) {
  if (!given) return;
  check_range(field, v, range.real());
  out = static_cast<int>(v);
}

Rgb color(const kiln::v1::Color& c, const std::string& field, const bounds::Range& range) {
  check_range(field + ".r", c.r(), range);
  check_range(field + ".g", c.g(), range);
  check_range(field + ".b", c.b(), range);
  return Rgb{c.r(), c.g(), c.b()};
}

InvalidField baker_problem(const std::string& prefix, const bake::InvalidInput& problem) {
  return InvalidField(problem.field().empty() ? prefix : prefix + "." + problem.field(), problem.problem());
}

BlobRef input_blob(const kiln::v1::Digest& d, const std::string& field, const store::BlobStore* blobs) {
  if (!proto::is_valid_sha256_hex(d.sha256())) {
    throw InvalidField(field + ".sha256", "must be 64 lowercase hex digits, got '" + d.sha256().substr(0, 80) + "'");
  }
  if (d.size() == 0)
    throw InvalidField(field + ".size", "an input (image or mesh) is not empty; got a blob of 0 bytes");
  if (d.size() > kMaxInputBlobBytes) {
    throw InvalidField(field + ".size", "an input blob is at most " + std::to_string(kMaxInputBlobBytes >> 20) +
                                            " MiB, got " + std::to_string(d.size()) +
                                            " bytes; scale an image down (16384 x 8192 RGB half EXR is ~400 MiB), "
                                            "split a mesh");
  }
  if (blobs && !blobs->contains(store::BlobId{d.sha256(), d.size()})) {
    throw InvalidField(field, "blob " + d.sha256() + " (" + std::to_string(d.size()) +
                                  " bytes) is not in the server's store; upload it (BlobPut) before submitting");
  }
  return BlobRef{field, d.sha256(), d.size()};
}

std::string read_input(const BlobRef& ref, store::BlobStore& blobs) {
  const store::BlobId id{ref.sha256, ref.size};
  if (!blobs.contains(id)) {
    throw InvalidField(ref.field, "blob " + ref.sha256 +
                                      " is no longer in the server's store (removed by its "
                                      "retention limit); upload it again and resubmit the job");
  }
  return blobs.read(id);  // verified against the digest
}

void check_color_space(const std::string& name, const std::string& field) {
  if (name.size() > kMaxColorSpaceBytes) {
    throw InvalidField(field, "at most 64 bytes, got " + std::to_string(name.size()));
  }
  const image::ColorConfig& config = image::ColorConfig::active();
  if (!config.has_space(name)) {
    std::string known;
    for (const std::string& space : config.spaces()) known += (known.empty() ? "" : ", ") + space;
    throw InvalidField(field,
                       "'" + name + "' is not a colour space or role of " + config.source() + "; known: " + known);
  }
}

std::map<std::string, bool> forced_effects(const kiln::v1::JobSpec& spec) {
  std::map<std::string, bool> out;
  for (const auto& [effect, on] : spec.force_effects()) {
    if (effect.empty() || effect.size() > kMaxEffectNameBytes) {
      throw InvalidField("job.force_effects[" + effect.substr(0, kMaxEffectNameBytes) + "]",
                         "effect names are 1 to 64 bytes, got " + std::to_string(effect.size()));
    }
    out[effect] = on;
  }
  return out;
}

}  // namespace kiln::daemon::detail
