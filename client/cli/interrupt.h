// Ctrl-C during `kiln bake`: the first press asks for the job to be cancelled on the server, the second quits at
// once and leaves the job running.
#pragma once

namespace kiln::cli {

// Thrown out of a watch once Ctrl-C was pressed, so that the caller can cancel the job.
struct Interrupted {};

// Ctrl-C from now on: the first press is remembered (ctrl_c_pressed) and said on stderr, the second quits.
void cancel_job_on_ctrl_c();
// Ctrl-C from now on just quits.
void quit_on_ctrl_c();
bool ctrl_c_pressed();

}  // namespace kiln::cli
