// The JUnit XML report of `kiln build` (--report-junit FILE), which the test reporters of GitLab, Jenkins and
// GitHub read: one test suite for the manifest, one test case per bake with its time, its error estimate and
// cost in system-out, and a <failure> (the job failed or missed a check), an <error> (the build could not finish
// it: a lost connection, an output that could not be written) or <skipped> (not submitted after a failure). The
// document follows the Jenkins/Ant JUnit schema (tests/integration/junit.xsd validates it).
#pragma once

#include <string>

#include "client/cli/build_plan.h"
#include "client/cli/build_runner.h"

namespace kiln::cli {

// `timestamp_unix`: when the build started; `hostname`: the machine it ran on.
std::string junit_xml(const BuildPlan& plan, const BuildOutcome& outcome, const std::string& manifest,
                      double timestamp_unix, const std::string& hostname);

// `s` escaped for XML text and attribute values; control characters XML 1.0 cannot carry become U+FFFD.
std::string xml_escape(const std::string& s);

}  // namespace kiln::cli
