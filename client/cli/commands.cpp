#include "client/cli/commands.h"

#include <algorithm>
#include <optional>
#include <ostream>

#include "client/cli/args.h"
#include "client/cli/bake_flags.h"
#include "client/cli/command_help.h"
#include "client/cli/context.h"
#include "client/cli/env_flags.h"
#include "client/cli/lightmap_flags.h"
#include "client/cli/probes_flags.h"
#include "client/cli/subcommands.h"

namespace kiln::cli {
namespace {

using client::ConnectionError;
using client::ServerError;

constexpr const char* kVersion = "kiln 0.1.0 (protocol kiln.v1)";

struct Command {
  const char* name;
  const char* help;
  std::vector<FlagSpec> flags;  // besides the global ones
  int (*run)(Context&, const Flags&);
};

const std::vector<Command>& commands() {
  static const std::vector<Command> kCommands = {
      {"submit", kSubmitHelp, {{"--wait", false}, {"--out"}, {"--priority"}, {"--idempotency-key"}}, cmd_submit},
      {"bake", kBakeMaterialHelp, {}, cmd_bake},
      {"build",
       kBuildHelp,
       {{"--jobs"}, {"--keep-going", false}, {"--only", true, true}, {"--report-junit"}, {"--report-json"}},
       cmd_build},
      {"watch", kWatchHelp, {}, cmd_watch},
      {"result", kResultHelp, {{"--json", false}}, cmd_result},
      {"fetch", kFetchHelp, {{"--out"}}, cmd_fetch},
      {"cancel", kCancelHelp, {}, cmd_cancel},
      {"status", kStatusHelp, {}, cmd_status},
      {"jobs", kJobsHelp, {{"--limit"}, {"--state"}}, cmd_jobs},
  };
  return kCommands;
}

const Command* find_command(const std::string& name) {
  for (const auto& c : commands()) {
    if (name == c.name) return &c;
  }
  return nullptr;
}

std::string command_names() {
  std::string names;
  for (const auto& c : commands()) names += (names.empty() ? "" : ", ") + std::string(c.name);
  return names;
}

const std::vector<std::string> kGlobalsWithValue = {"--server", "--token-file", "--tls-ca", "--tls-cert", "--tls-key"};

bool is_global_with_value(const std::string& arg) {
  return std::find(kGlobalsWithValue.begin(), kGlobalsWithValue.end(), arg) != kGlobalsWithValue.end();
}
// "--server=ADDR" and the like.
bool is_global_with_joined_value(const std::string& arg) {
  const auto eq = arg.find('=');
  return eq != std::string::npos && is_global_with_value(arg.substr(0, eq));
}
bool is_env_type(const std::string& bake_type) { return bake_type == "env" || bake_type == "environment"; }

// Where the command is on the line: the first word that is neither a global flag nor its value. When --help or
// --version comes first, nullopt with `answer` set to the text to print.
std::optional<std::size_t> find_command_word(const std::vector<std::string>& args, std::string& answer) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (is_global_with_value(a)) {
      ++i;
      continue;
    }
    if (a == "--") break;
    if (a.empty() || a[0] != '-' || a == "-") return i;
    if (a == "--help" || a == "-h") {
      answer = kHelp;
      return std::nullopt;
    }
    if (a == "--version") {
      answer = std::string(kVersion) + "\n";
      return std::nullopt;
    }
    if (is_global_with_joined_value(a)) continue;
    throw UsageError("unknown option " + a + " before the command (see `kiln --help`)");
  }
  return std::nullopt;
}

// `kiln bake TYPE`: the type is the first word that is not a flag (global flags' values skipped).
std::string bake_type_of(const std::vector<std::string>& rest) {
  for (std::size_t i = 0; i < rest.size(); ++i) {
    if (is_global_with_value(rest[i])) {
      ++i;
      continue;
    }
    if (!rest[i].empty() && rest[i][0] != '-') return rest[i];
  }
  return "";
}

// The help of `command` (for `kiln bake`, of the bake type).
const char* help_of(const Command& command, const std::string& bake_type) {
  if (is_env_type(bake_type)) return kBakeEnvHelp.c_str();
  if (bake_type == "probes") return kBakeProbesHelp.c_str();
  return bake_type == "lightmap" ? kBakeLightmapHelp.c_str() : command.help;
}

// `kiln help [COMMAND [TYPE]]`, from the words after `help`.
int print_help(Context& ctx, const std::vector<std::string>& rest) {
  std::vector<std::string> words;
  for (const auto& w : rest) {
    if (!w.empty() && w[0] != '-') words.push_back(w);
  }
  if (words.empty()) {
    ctx.out << kHelp;
    return kExitOk;
  }
  const Command* c = find_command(words[0]);
  if (!c) throw UsageError("no command '" + words[0] + "': expected one of " + command_names());
  ctx.out << help_of(*c, words[0] == "bake" && words.size() > 1 ? words[1] : "");
  return kExitOk;
}

// --help wins over everything else on the line, so that a half-typed command can still ask for its help.
bool asks_for_help(const std::vector<std::string>& rest) {
  for (const auto& a : rest) {
    if (a == "--") break;
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

std::vector<FlagSpec> flag_specs_of(const Command& command, const std::string& bake_type) {
  if (std::string(command.name) == "bake") {
    if (is_env_type(bake_type)) return bake_env_flag_specs();
    if (bake_type == "probes") return bake_probes_flag_specs();
    return bake_type == "lightmap" ? bake_lightmap_flag_specs() : bake_material_flag_specs();
  }
  std::vector<FlagSpec> specs = command.flags;
  for (auto& g : global_flag_specs()) specs.push_back(std::move(g));
  return specs;
}

// The command as errors name it: "kiln jobs", "kiln bake env".
std::string full_name_of(const std::string& name, const std::string& bake_type) {
  if (name != "bake") return "kiln " + name;
  if (is_env_type(bake_type)) return "kiln bake env";
  if (bake_type == "probes") return "kiln bake probes";
  return bake_type == "lightmap" ? "kiln bake lightmap" : "kiln bake material";
}

int run(const std::vector<std::string>& args, Context& ctx) {
  std::string answer;
  const std::optional<std::size_t> at = find_command_word(args, answer);
  if (!answer.empty()) {
    ctx.out << answer;
    return kExitOk;
  }
  if (!at) throw UsageError("missing command: expected one of " + command_names() + " (see `kiln --help`)");
  const std::string name = args[*at];
  std::vector<std::string> rest(args.begin(), args.begin() + static_cast<std::ptrdiff_t>(*at));
  rest.insert(rest.end(), args.begin() + static_cast<std::ptrdiff_t>(*at) + 1, args.end());
  if (name == "help") return print_help(ctx, rest);

  const Command* command = find_command(name);
  if (!command) {
    throw UsageError("unknown command '" + name + "': expected one of " + command_names() + " (see `kiln --help`)");
  }
  const std::string bake_type = name == "bake" ? bake_type_of(rest) : "";
  if (asks_for_help(rest)) {
    ctx.out << help_of(*command, bake_type);
    return kExitOk;
  }
  const Flags flags = parse_flags(rest, flag_specs_of(*command, bake_type), full_name_of(name, bake_type));
  set_server_and_token(ctx, flags);
  return command->run(ctx, flags);
}

}  // namespace

int run_kiln(const std::vector<std::string>& args, std::ostream& out, std::ostream& err, const Terminal& terminal) {
  Context ctx{{}, {}, {}, {}, terminal, out, err, std::nullopt, {}};
  try {
    return run(args, ctx);
  } catch (const UsageError& e) {
    err << "kiln: " << e.what() << "\n";
    return kExitUsage;
  } catch (const Failure& e) {
    err << "kiln: " << e.what() << "\n";
    return e.status();
  } catch (const ConnectionError& e) {
    err << "kiln: lost the connection to kilnd at " << ctx.server << ": " << e.what() << "\n";
    return kExitServer;
  } catch (const ServerError& e) {
    err << "kiln: kilnd at " << ctx.server << " answered with an error: " << describe_server_error(e) << "\n";
    return e.code() == v1::Error::INVALID_ARGUMENT ? kExitUsage : kExitServer;
  } catch (const std::exception& e) {
    err << "kiln: " << e.what() << "\n";
    return kExitServer;
  }
}

}  // namespace kiln::cli
