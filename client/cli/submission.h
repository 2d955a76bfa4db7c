// Submitting a job: the submission's flags (--priority, --idempotency-key) and the server's refusals told in the
// words the user wrote.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "client/cli/context.h"

namespace kiln::cli {

// Where the user gave a field the server names: "FILE:LINE:COL", "--flag" or a file; "" if nowhere.
using FieldOrigin = std::function<std::string(const std::string& field_path)>;

// Submits `spec`; a refusal becomes a Failure that names the field through `where`.
v1::SubmitReply submit_job(Context& ctx, const v1::JobSpec& spec, std::int32_t priority, const std::string& key,
                           const FieldOrigin& where);

// --priority, [-100, 100], default 0; --idempotency-key, at most 128 bytes. Throw UsageError.
std::int32_t priority_of(const Flags& f);
std::string idempotency_key_of(const Flags& f);

}  // namespace kiln::cli
