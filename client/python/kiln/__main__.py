"""python -m kiln: the basics of the `kiln` command line (submit, watch, result, fetch, status) for machines that
have Python but not the C++ client. Same flags, environment and exit status as `kiln`:

  0  the job succeeded (status: the server answered)
  1  the job failed or was cancelled (result, fetch: or has not finished yet)
  2  usage error, an unreadable or malformed job file, a job field the server refused, an unknown job id
  3  no connection, the token refused, another server error, or the outputs could not be written
"""

import argparse
import sys

from . import Client, ConnectionError, KilnError, ServerError, load_job, pb, state_name

USAGE_CODES = (pb.Error.INVALID_ARGUMENT, pb.Error.NOT_FOUND)


def _parser():
    p = argparse.ArgumentParser(prog="python -m kiln",
                                description="Submit bake jobs to kilnd, follow them and fetch what they made.")
    p.add_argument("--server", help="HOST:PORT or unix:PATH; default $KILN_SERVER, else 127.0.0.1:7878")
    p.add_argument("--token-file", help="the token's file; default $KILN_TOKEN, else the file $KILN_TOKEN_FILE")
    p.add_argument("--tls-ca", help="connect over TLS trusting these CA certificates (PEM); default $KILN_TLS_CA")
    p.add_argument("--tls-cert", help="this client's certificate (PEM); default $KILN_TLS_CERT")
    p.add_argument("--tls-key", help="this client's key (PEM); default $KILN_TLS_KEY")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    s = sub.add_parser("submit", help="submit a job file (kiln.v1.JobSpec in protobuf text format)")
    s.add_argument("job", metavar="JOB.textproto")
    s.add_argument("--wait", action="store_true", help="follow the job until it ends")
    s.add_argument("--out", metavar="DIR", help="wait, then write every output into DIR")
    s.add_argument("--priority", type=int, default=0, help="higher runs first, [-100, 100]")
    s.add_argument("--idempotency-key", default="", help="the same key and spec return the first job")
    w = sub.add_parser("watch", help="follow a job until it ends, showing its progress")
    w.add_argument("id", metavar="ID")
    r = sub.add_parser("result", help="a finished job's outcome and outputs")
    r.add_argument("id", metavar="ID")
    f = sub.add_parser("fetch", help="write a finished job's outputs into DIR")
    f.add_argument("id", metavar="ID")
    f.add_argument("--out", metavar="DIR", required=True)
    sub.add_parser("status", help="the server's version, queue, workers and store use")
    return p


def _progress(event):
    line = "%s %s %3.0f %%" % (event.job_id, state_name(event.state), 100.0 * event.fraction)
    if event.message:
        line += "  " + event.message
    print(line, file=sys.stderr, flush=True)


def _follow(client, job_id):
    final = client.watch(job_id, on_event=_progress)
    if final.state == pb.JOB_STATE_SUCCEEDED:
        return 0
    result = client.result(job_id)
    reason = result.error.message if result.HasField("error") and result.error.message else final.message
    print("kiln: job %s %s%s" % (job_id, state_name(final.state), ": " + reason if reason else ""), file=sys.stderr)
    return 1


def _print_result(result):
    print("%s %s" % (result.job_id, state_name(result.state)))
    for output in result.outputs:
        print("  %-32s %s %d bytes" % (output.name, output.digest.sha256, output.digest.size))


def _fetch(client, job_id, out_dir):
    result = client.result(job_id)
    if result.state != pb.JOB_STATE_SUCCEEDED:
        print("kiln: job %s is %s: it has no outputs to fetch" % (job_id, state_name(result.state)), file=sys.stderr)
        return 1
    try:
        paths = client.fetch_outputs(job_id, out_dir)
    except OSError as e:
        print("kiln: cannot write the outputs of job %s into %s: %s" % (job_id, out_dir, e), file=sys.stderr)
        return 3
    for path in paths:
        print(path)
    return 0


def _run(args, client):
    if args.command == "submit":
        try:
            job = load_job(args.job)
        except (OSError, ValueError) as e:
            print("kiln: cannot read job file %s: %s" % (args.job, e), file=sys.stderr)
            return 2
        reply = client.submit(job, priority=args.priority, idempotency_key=args.idempotency_key)
        print(reply.job_id, flush=True)
        if reply.cache_hit:
            print("kiln: job %s answered from the result cache" % reply.job_id, file=sys.stderr)
        if not (args.wait or args.out):
            return 0
        status = _follow(client, reply.job_id)
        if status or not args.out:
            return status
        return _fetch(client, reply.job_id, args.out)
    if args.command == "watch":
        return _follow(client, args.id)
    if args.command == "result":
        result = client.result(args.id)
        _print_result(result)
        return 0 if result.state == pb.JOB_STATE_SUCCEEDED else 1
    if args.command == "fetch":
        return _fetch(client, args.id, args.out)
    status = client.status()
    print(status)
    return 0


def main(argv=None):
    args = _parser().parse_args(argv)
    try:
        with Client(args.server, token_file=args.token_file, tls_ca=args.tls_ca, tls_cert=args.tls_cert,
                    tls_key=args.tls_key) as client:
            return _run(args, client)
    except ServerError as e:
        print("kiln: the server refused the request: %s" % e, file=sys.stderr)
        return 2 if e.code in USAGE_CODES else 3
    except ConnectionError as e:
        print("kiln: %s" % e, file=sys.stderr)
        return 3
    except KilnError as e:
        print("kiln: %s" % e, file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print("kiln: interrupted; the job goes on in kilnd", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
