// One decision of a planner: an effect simulated or skipped, and why. The bakers' planners return a list of these;
// the report and the wire protocol (PlanDecision) carry them unchanged.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bakers/bake/invalid_input.h"

namespace kiln::plan {

struct Decision {
  std::string effect;  // a stable name, e.g. "specular_interreflection"; jobs force effects by it
  bool enabled = false;
  bool forced = false;  // by the job's force_effects rather than by the planner
  std::string reason;   // for people: what in the scene led to this
};

// nullopt if every name in `forced` is one of `known`, else the field "force_effects[x]" with the problem
// 'unknown effect "x"; known effects: a, b, ...'.
std::optional<bake::InvalidInput> check_forced_names(const std::map<std::string, bool>& forced,
                                                     const std::vector<std::string>& known);

// Records the planner's decision for `effect`, or the job's forced value with both reasons kept.
Decision decide(const std::string& effect, bool planned, const std::string& reason,
                const std::map<std::string, bool>& forced);

}  // namespace kiln::plan
