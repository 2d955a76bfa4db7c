// The --help texts of `kiln` and of its commands (the bake commands' are beside their flags: bake_flags.h,
// env_flags.h, lightmap_flags.h).
#pragma once

namespace kiln::cli {

extern const char* const kHelp;
extern const char* const kSubmitHelp;
extern const char* const kBuildHelp;
extern const char* const kWatchHelp;
extern const char* const kResultHelp;
extern const char* const kFetchHelp;
extern const char* const kCancelHelp;
extern const char* const kStatusHelp;
extern const char* const kJobsHelp;

}  // namespace kiln::cli
