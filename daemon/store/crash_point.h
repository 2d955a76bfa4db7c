// Crash points: places where a crash would leave the store in a state of its own (a partial upload, a blob synced but
// not renamed, a job committed but not answered), so that the crash-consistency test can kill kilnd exactly there.
// With KILND_CRASH_AT=NAME:N in kilnd's environment, the N-th time any thread passes crash point NAME the process
// sends itself SIGKILL: no destructor, no flush, as a power cut or the kernel's OOM killer would. Without the variable
// a crash point costs one relaxed load. The variable is read once, at the first crash point passed.
//
// Names (each at the place it is passed):
//   blob.append         after a chunk of an upload is written to its partial file
//   blob.complete       a whole upload verified and synced, before its rename into the store
//   blob.put            a result file written and synced, before its rename into the store
//   blob.installed      a blob renamed into place and its directory synced
//   job.inserted        a submitted job's record committed, before the client is answered
//   job.running         a job marked running, before its bake starts
//   job.succeeded       a job's result committed, before its watchers are told
#pragma once

namespace kiln::store {

void crash_point(const char* name);

}  // namespace kiln::store
