// The commands of `kiln`, a function each: they read their flags, talk to kilnd through `ctx`, print, and return
// the exit status, or throw UsageError or Failure. commands.cpp picks one from the command line.
#pragma once

#include "client/cli/args.h"
#include "client/cli/context.h"

namespace kiln::cli {

// bake_commands.cpp
int cmd_bake(Context& ctx, const Flags& f);
// build_command.cpp
int cmd_build(Context& ctx, const Flags& f);
// job_commands.cpp
int cmd_submit(Context& ctx, const Flags& f);
int cmd_watch(Context& ctx, const Flags& f);
int cmd_result(Context& ctx, const Flags& f);
int cmd_fetch(Context& ctx, const Flags& f);
int cmd_cancel(Context& ctx, const Flags& f);
// server_commands.cpp
int cmd_status(Context& ctx, const Flags& f);
int cmd_jobs(Context& ctx, const Flags& f);

}  // namespace kiln::cli
