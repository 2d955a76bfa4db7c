#include "bakers/plan/decision.h"

#include <algorithm>

namespace kiln::plan {

std::optional<bake::InvalidInput> check_forced_names(const std::map<std::string, bool>& forced,
                                                     const std::vector<std::string>& known) {
  for (const auto& [name, value] : forced) {
    if (std::find(known.begin(), known.end(), name) != known.end()) continue;
    std::string list;
    for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
    return bake::InvalidInput("force_effects[" + name + "]", "unknown effect \"" + name + "\"; known effects: " + list);
  }
  return std::nullopt;
}

Decision decide(const std::string& effect, bool planned, const std::string& reason,
                const std::map<std::string, bool>& forced) {
  Decision d{effect, planned, false, reason};
  if (auto it = forced.find(effect); it != forced.end()) {
    d.forced = true;
    d.enabled = it->second;
    d.reason = std::string("forced ") + (it->second ? "on" : "off") + " by the job (the planner would have " +
               (planned ? "enabled" : "disabled") + " it: " + reason + ")";
  }
  return d;
}

}  // namespace kiln::plan
