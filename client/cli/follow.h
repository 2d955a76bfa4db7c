// Following a job to its end with progress on stderr, and what `kiln` does once it has ended: the result, the
// outputs written into a folder, or the Failure that says why the job did not succeed.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "client/cli/context.h"

namespace kiln::cli {

// Follows job `id` until it ends, showing progress on stderr, and returns the final event. A broken connection is
// re-attached (the first event of a watch is the job's current state, so nothing is missed). With
// `cancel_on_ctrl_c`, throws Interrupted once Ctrl-C was pressed.
v1::JobEvent follow_job(Context& ctx, const std::string& id, bool cancel_on_ctrl_c);

// The result of job `id`, or a Failure that says why not. With `unfinished_hint`, a job that has not finished is a
// Failure with status 1 whose message ends with the hint; without, it is a server error like any other.
v1::JobResult request_result(Context& ctx, const std::string& id,
                             const std::optional<std::string>& unfinished_hint = std::nullopt);

// Cancels job `id` and returns the state it is in afterwards, or a Failure that says why it could not.
v1::JobState request_cancel(Context& ctx, const std::string& id);

// After the final event: on success, prints the result's summary (having saved the outputs into `dir` if given);
// otherwise throws a Failure with status 1 that says how the job ended.
int save_and_summarize(Context& ctx, const v1::JobEvent& final, const std::string& id,
                       const std::optional<std::filesystem::path>& dir, bool cache_hit);

}  // namespace kiln::cli
