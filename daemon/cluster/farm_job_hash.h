// A farm job as Redis keeps it (docs/SCALING.md): the fields of its hash kiln:job:ID, decoded into the same
// store::JobRecord the SQLite store returns, and a progress event as the text published on kiln:ev:ID.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "daemon/cluster/redis_client.h"
#include "daemon/store/job_queue.h"

namespace kiln::cluster {

// A job's hash as HGETALL returns it (field, value, field, value, …). Throws RedisError(protocol) for a hash that
// lacks its id's fields or holds a state no kilnd writes.
store::JobRecord decode_job(const std::string& id, const RedisReply& hgetall);

// Seconds since the epoch, written so that decoding gives back the same double.
std::string encode_time(double seconds);

// "STATE\nFRACTION\nETA\nSAMPLES\nERROR\nMESSAGE": unknown numbers are empty, the message (which may hold newlines)
// comes last. The commit scripts write the same layout for final events.
std::string encode_progress(const store::Progress& p);
// Nothing for a payload of another layout (from a newer kilnd, or not kiln's).
std::optional<store::Progress> decode_progress(const std::string& payload);

}  // namespace kiln::cluster
