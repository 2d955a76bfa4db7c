// Job names are the client's text: control characters in them must not forge a line of kilnd's log, nor reach a
// terminal through the command line's output (issue 19, defect 9). The real kilnd and the real `kiln`.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/service_client.h"
#include "tests/support/run_command.h"

namespace kiln {
namespace {

using test::Daemon;

// A name that, printed raw, ends the line and starts a forged one, then turns a terminal's text red.
const std::string kForgery = "2026-01-01T00:00:00Z kilnd: job 0000: succeeded";
const std::string kName = "lamp\n" + kForgery + "\r\x1b[31mred\x07";
const std::string kEscaped = "lamp\\n" + kForgery + "\\r\\x1b[31mred\\x07";

#ifdef KILN_BIN
std::string kiln(const Daemon& d, const std::string& args) {
  const std::string token = (d.dir() / "cli-token").string();
  std::ofstream(token) << d.token() << "\n";
  const std::string command =
      std::string(KILN_BIN) + " --server " + d.tcp() + " --token-file " + token + " " + args + " 2>&1";
  return test::run_command(command).output;
}

TEST(JobNames, ControlCharactersAreEscapedInTheLogAndTheCommandLine) {
  Daemon d;
  client::Client c = test::connect(d);
  v1::JobSpec spec;
  spec.set_name(kName);
  spec.mutable_material()->mutable_ggx()->set_alpha(0.5);
  spec.mutable_material()->set_table_mu(8);
  spec.mutable_material()->set_table_roughness(8);
  spec.mutable_quality()->set_samples(64);
  const std::string id = c.submit(spec).job_id();
  ASSERT_EQ(c.watch(id).state(), v1::JOB_STATE_SUCCEEDED) << d.log();

  // kilnd logs the name when the job runs: on its line, escaped.
  const std::string log = d.log();
  EXPECT_EQ(log.find("\n" + kForgery), std::string::npos) << log;
  EXPECT_EQ(log.find('\x1b'), std::string::npos) << log;
  EXPECT_NE(log.find(kEscaped), std::string::npos) << log;

  for (const std::string& args : {std::string("jobs"), "result " + id}) {
    const std::string said = kiln(d, args);
    EXPECT_EQ(said.find("\n" + kForgery), std::string::npos) << args << ":\n" << said;
    EXPECT_EQ(said.find_first_of("\r\x1b\x07"), std::string::npos) << args << ":\n" << said;
    EXPECT_NE(said.find(kEscaped), std::string::npos) << args << ":\n" << said;
  }
}
#endif

}  // namespace
}  // namespace kiln
