#include "client/cli/command_help.h"

namespace kiln::cli {

const char* const kHelp = R"(usage: kiln [--server ADDR] [--token-file FILE] [--tls-ca FILE] COMMAND [ARGS]

kiln talks to kilnd, the kiln baking daemon: it submits bake jobs, follows them and fetches what they made.

commands:
  submit JOB.textproto [--wait] [--out DIR] [--priority N] [--idempotency-key KEY]
                        submit a job file (a kiln.v1.JobSpec in protobuf text format; see client/examples/)
  bake material --model MODEL [parameters] --out DIR
                        bake one material described by flags, wait, write its outputs and report.json into DIR
  bake env IMAGE | --constant R,G,B | --faces PX NX PY NY PZ NZ [options] [--out DIR]
                        upload an HDR environment and bake it for image-based lighting (specular cube chain,
                        irradiance, SH, DFG table); with --out, wait and write the outputs into DIR
  bake lightmap SCENE [--env IMAGE | --env-constant R,G,B] [--resolution N] [--target-error E] [options] --out DIR
                        import a glTF, OBJ or FBX scene, upload it and bake its lightmaps (irradiance, validity,
                        error, preview; optionally radiance, AO, SH); with --out, wait and write them into DIR
  build [MANIFEST] [--jobs N] [--keep-going] [--only NAME...] [--report-junit FILE] [--report-json FILE]
                        bake every bake of a build manifest (kiln.build.textproto) that changed, check them, write
                        their output folders, report like a test suite (see `kiln build --help`)
  watch ID              follow a job until it ends, showing its progress
  result ID [--json]    a finished job's outcome: cost, planner decisions, outputs with their digests
  fetch ID --out DIR    write a finished job's outputs and report.json into DIR
  cancel ID             cancel a queued or running job
  status                the server: version, queue, workers, store use, cache hits, limits
  jobs [--limit N] [--state STATE]   recent jobs, newest first
  help [COMMAND]        this text, or a command's (also `kiln COMMAND --help`)

global options (anywhere on the line):
  --server ADDR         HOST:PORT ([::1]:7878 for IPv6) or unix:PATH; default $KILN_SERVER, else 127.0.0.1:7878
  --token-file FILE     the token, from the first line of FILE that is not blank or a # comment; default
                        $KILN_TOKEN, else the file named by $KILN_TOKEN_FILE. TCP needs a token; on a Unix socket
                        the socket's file permissions decide and the token is not needed.
  --tls-ca FILE         connect over TLS, trusting the CA certificates in FILE (PEM) for the server's certificate,
                        which must also name the host of --server; default $KILN_TLS_CA. TCP only.
  --tls-cert FILE, --tls-key FILE
                        this client's certificate and key (PEM), for a kilnd that requires client certificates;
                        default $KILN_TLS_CERT, $KILN_TLS_KEY
  --version             print the client's version

Progress goes to stderr: a bar redrawn in place on a terminal, otherwise plain lines (one per 10 % of progress, at
most one a second, and one at least every 30 s). Job ids, summaries and tables go to stdout.

exit status:
  0  the job succeeded (cancel: the job is cancelled; status, jobs: the server answered)
  1  the job failed or was cancelled (result, fetch: or has not finished yet)
  2  usage error: bad flags, an unreadable or malformed job file, a job field the server refused, an unknown job id
  3  no connection, the token refused, another server error, or the outputs could not be written
)";

const char* const kBuildHelp = R"(usage: kiln build [MANIFEST] [--jobs N] [--keep-going] [--only NAME]...
                  [--report-junit FILE] [--report-json FILE]

Bakes the bakes of a build manifest (MANIFEST, or a folder holding one; default ./kiln.build.textproto: a
kiln.build.v1.Manifest in protobuf text format, see proto/kiln_build.proto and client/examples/build/). Each bake
is a job file, the words of a `kiln bake` command, or such a command over the files a glob matches, with an output
folder; paths are relative to the manifest.

The build uploads the inputs the server lacks (asking for every digest first), submits the bakes, follows them on
one connection, checks each result against the bake's checks, and writes each output folder whole, in one rename,
once its bake has succeeded: a failed bake leaves its folder as it was. A bake whose job is unchanged is a cache
hit, and files already on disk with the right bytes are not rewritten (their modification times stay).

  --jobs N               at most N bakes submitted and unfinished at a time; default all (the server's queue
                         decides the order they run in)
  --keep-going           after a bake fails, submit the rest all the same (without: they are skipped, the bakes
                         already submitted finish)
  --only NAME            bake only this one (repeatable); a glob's bakes are NAME (all of them) or NAME/STEM
  --report-junit FILE    write a JUnit XML report: one test case per bake, with its time, its error estimate, and
                         why it failed (GitLab, Jenkins and GitHub read it)
  --report-json FILE     write a JSON summary: the totals and each bake's outcome

At the end, a summary on stdout: bakes baked, cached and failed, the time the cache saved, each failure.

exit status: 0 every bake succeeded and passed its checks; 1 a bake failed, missed a check or could not be written;
2 a usage error (the manifest, a command in it, a missing input); 3 no connection, or it was lost
)";

const char* const kSubmitHelp = R"(usage: kiln submit JOB.textproto [--wait] [--out DIR] [--priority N]
                   [--idempotency-key KEY]

Submits the job in JOB.textproto (a kiln.v1.JobSpec in protobuf text format; "-" reads standard input). Without
--wait or --out, prints the job id on stdout and returns at once; follow it with `kiln watch ID`.

  --wait                 follow the job until it ends, with progress; the exit status says how it ended
  --out DIR              wait, then write every output (by its name) and report.json into DIR, created if missing
  --priority N           higher runs first, [-100, 100]; default 0
  --idempotency-key KEY  at most 128 bytes; submitting the same key and spec again returns the first job instead
                         of a new one (a retried CI step does not bake twice)

Errors in the file are reported with its line and column, including fields the server refuses.
Images a job reads (environment { image { sha256: ... size: ... } }) are blobs the server must already hold;
`kiln bake env IMAGE` uploads a local file and submits in one step.
Examples: client/examples/*.textproto. See `kiln --help` for --server, --token-file and the exit status.
)";

const char* const kWatchHelp = R"(usage: kiln watch ID

Follows job ID until it ends: state, fraction done, ETA, samples and error estimate on stderr (a bar on a terminal,
plain lines otherwise). A broken connection is re-attached for about a minute. Ctrl-C stops watching; the job goes
on. On success prints what the bake cost; fetch the outputs with `kiln fetch ID --out DIR`.
Exit status 0 if the job succeeded, 1 if it failed or was cancelled.
)";

const char* const kResultHelp = R"(usage: kiln result ID [--json]

Prints the outcome of finished job ID: its state (and why it failed), what it cost (samples, rays, seconds, error
estimate, cache hit), the planner's decisions, and each output with its size, media type, colour space and SHA-256.
  --json   print the same as JSON instead (the shape of the report.json that `kiln fetch` writes when the server
           sends no report of its own)
Exit status 0 if the job succeeded, 1 if it failed, was cancelled or has not finished.
)";

const char* const kFetchHelp = R"(usage: kiln fetch ID --out DIR

Writes every output of finished job ID into DIR (created if missing), each under its output name, and report.json.
Each file's bytes are verified against the SHA-256 digest in the result before the file is kept.
Exit status 0 when all were written, 1 if the job failed, was cancelled or has not finished, 3 on a server or
write error.
)";

const char* const kCancelHelp = R"(usage: kiln cancel ID

Cancels job ID if it is queued or running. Exit status 0 if the job is cancelled (now or before), 1 if it had
already succeeded or failed.
)";

const char* const kStatusHelp = R"(usage: kiln status

Prints the server's version, uptime, queue (queued, running), workers and threads, store use, cache hits, jobs
completed and failed, connections, the job types it bakes and its limits.
)";

const char* const kJobsHelp = R"(usage: kiln jobs [--limit N] [--state STATE]

Lists jobs, newest first: id, state, type, priority, submission time, seconds of baking, cache hit, name.
  --limit N        at most N jobs, [1, 1000]; default the server's (100)
  --state STATE    only jobs in STATE: queued, running, succeeded, failed or cancelled
)";

}  // namespace kiln::cli
