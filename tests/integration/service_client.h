// What the integration tests ask of a running kilnd through the C++ client library: a connection that has said
// Hello, and a material job whose size sets how long it bakes (milliseconds at the defaults, minutes at 2^20 samples
// over 64 × 64 tables).
#pragma once

#include <cstdint>
#include <string>

#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"

namespace kiln::test {

inline client::Client connect(const Daemon& d, bool unix_socket = false) {
  client::Client c(unix_socket ? d.unix_address() : d.tcp());
  c.hello(d.token());
  return c;
}

// Whether a fresh connection's Hello lists `type` among the job types the server bakes.
inline bool serves_job_type(const Daemon& d, const std::string& type) {
  client::Client fresh(d.tcp());
  const v1::HelloReply hello = fresh.hello(d.token());
  for (const std::string& t : hello.job_types())
    if (t == type) return true;
  return false;
}

inline v1::JobSpec ggx_job(double alpha, uint64_t samples = 1024, int table = 8) {
  v1::JobSpec spec;
  spec.set_name("ggx " + std::to_string(alpha));
  spec.mutable_material()->mutable_ggx()->set_alpha(alpha);
  spec.mutable_material()->set_table_mu(table);
  spec.mutable_material()->set_table_roughness(table);
  spec.mutable_quality()->set_samples(samples);
  return spec;
}

}  // namespace kiln::test
