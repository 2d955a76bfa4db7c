#include "client/cli/submission.h"

#include "proto/bounds.h"

namespace kiln::cli {
namespace {

using client::ConnectionError;
using client::ServerError;

constexpr std::size_t kMaxIdempotencyKeyBytes = 128;

}  // namespace

v1::SubmitReply submit_job(Context& ctx, const v1::JobSpec& spec, std::int32_t priority, const std::string& key,
                           const FieldOrigin& where) {
  try {
    return connected_client(ctx).submit(spec, priority, key);
  } catch (const ServerError& e) {
    if (e.code() == v1::Error::INVALID_ARGUMENT) {
      std::string at = e.field().empty() ? "" : where(e.field());
      if (e.field() == "priority") at = "--priority";
      if (e.field() == "idempotency_key") at = "--idempotency-key";
      const bool named = e.field().empty() || e.message().rfind(e.field() + ":", 0) == 0;
      throw Failure(kExitUsage, (at.empty() ? "" : at + ": ") +
                                    "the server refused the job: " + (named ? "" : e.field() + ": ") + e.message());
    }
    if (e.code() == v1::Error::RESOURCE_EXHAUSTED && !e.field().empty()) {
      // A limit a field of the job exceeds (the memory a lightmap's resolution needs): waiting would not help.
      const std::string at = where(e.field());
      throw Failure(kExitServer, "kilnd at " + ctx.server + " refused the job: " + (at.empty() ? e.field() : at) +
                                     ": " + e.message());
    }
    if (e.code() == v1::Error::RESOURCE_EXHAUSTED) {
      throw Failure(kExitServer, "kilnd at " + ctx.server + " cannot take the job now: " + e.message() +
                                     "; try again when its queue has room (`kiln status`)");
    }
    throw Failure(kExitServer, "kilnd at " + ctx.server + " could not take the job: " + describe_server_error(e));
  } catch (const ConnectionError& e) {
    throw_connection_lost(ctx, e, "submitting the job");
  }
}

std::int32_t priority_of(const Flags& f) {
  auto v = f.get("--priority");
  return v ? static_cast<std::int32_t>(parse_whole("--priority", *v, bounds::kPriority)) : 0;
}

std::string idempotency_key_of(const Flags& f) {
  const std::string key = f.get("--idempotency-key").value_or("");
  if (key.size() > kMaxIdempotencyKeyBytes) {
    throw UsageError("--idempotency-key: at most " + std::to_string(kMaxIdempotencyKeyBytes) + " bytes, got " +
                     std::to_string(key.size()));
  }
  return key;
}

}  // namespace kiln::cli
