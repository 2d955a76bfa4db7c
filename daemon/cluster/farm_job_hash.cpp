#include "daemon/cluster/farm_job_hash.h"

#include <charconv>
#include <cstdio>
#include <unordered_map>

namespace kiln::cluster {

namespace {

std::optional<double> to_double(const std::string& s) {
  if (s.empty()) return std::nullopt;
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

int64_t to_int(const std::string& s) {
  int64_t v = 0;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}

[[noreturn]] void damaged(const std::string& id, const std::string& what) {
  throw RedisError(RedisErrc::protocol, "the farm's record of job " + id + " is damaged: " + what);
}

// Splits at the first `count` newlines; the rest is the last part.
std::vector<std::string> split_lines(const std::string& s, size_t count) {
  std::vector<std::string> out;
  size_t start = 0;
  for (size_t i = 0; i < count; ++i) {
    const size_t nl = s.find('\n', start);
    if (nl == std::string::npos) return {};
    out.push_back(s.substr(start, nl - start));
    start = nl + 1;
  }
  out.push_back(s.substr(start));
  return out;
}

}  // namespace

std::string encode_time(double seconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", seconds);
  return buf;
}

store::JobRecord decode_job(const std::string& id, const RedisReply& hgetall) {
  const auto& items = hgetall.as_array();
  std::unordered_map<std::string, std::string> f;
  for (size_t i = 0; i + 1 < items.size(); i += 2) f[items[i].as_string()] = items[i + 1].as_string();
  if (!f.count("seq") || !f.count("state")) damaged(id, "it has no seq or state");
  store::JobRecord r;
  r.id = id;
  r.seq = to_int(f["seq"]);
  r.name = f["name"];
  r.type = f["type"];
  r.spec = f["spec"];
  r.spec_key = f["spec_key"];
  r.priority = static_cast<int32_t>(to_int(f["priority"]));
  const auto state = store::parse_job_state(f["state"]);
  if (!state) damaged(id, "unknown state '" + f["state"].substr(0, 20) + "'");
  r.state = *state;
  r.submitted = to_double(f["submitted"]).value_or(0);
  r.started = to_double(f["started"]);
  r.finished = to_double(f["finished"]);
  r.error = f["error"];
  r.result = f["result"];
  if (f.count("idem")) r.idempotency_key = f["idem"];
  r.input_digests = store::split_digests(f["inputs"]);
  r.output_digests = store::split_digests(f["outputs"]);
  r.last_used = to_double(f["last_used"]).value_or(r.submitted);
  r.attempts = static_cast<int32_t>(to_int(f["attempts"]));
  if (f.count("cache_source")) r.cache_source = f["cache_source"];
  r.evicted = to_double(f["evicted"]);
  return r;
}

std::string encode_progress(const store::Progress& p) {
  auto opt = [](const std::optional<double>& v) { return v ? encode_time(*v) : std::string(); };
  return std::string(store::to_string(p.state)) + "\n" + encode_time(p.fraction) + "\n" + opt(p.eta_seconds) + "\n" +
         std::to_string(p.samples) + "\n" + opt(p.error_estimate) + "\n" + p.message;
}

std::optional<store::Progress> decode_progress(const std::string& payload) {
  const std::vector<std::string> parts = split_lines(payload, 5);
  if (parts.size() != 6) return std::nullopt;
  const auto state = store::parse_job_state(parts[0]);
  if (!state) return std::nullopt;
  store::Progress p;
  p.state = *state;
  p.fraction = to_double(parts[1]).value_or(0);
  p.eta_seconds = to_double(parts[2]);
  p.samples = static_cast<uint64_t>(to_int(parts[3]));
  p.error_estimate = to_double(parts[4]);
  p.message = parts[5];
  return p;
}

}  // namespace kiln::cluster
