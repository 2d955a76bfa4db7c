#!/usr/bin/env bash
# kiln as installed: `cmake --install` into a scratch prefix; the installed files carry no path into the source or
# build tree; the installed kilnd runs with the installed kilnd.conf (only --listen changed, to a free port) and a
# token in the config's token file; the installed `kiln` bakes every installed example; the Python client, pip-installed
# into a fresh virtual environment (Debian's protobuf through --system-site-packages, no package index), submits the
# same jobs and fetches byte-identical outputs; a program built with find_package(kiln) says hello; pkg-config finds
# the library; systemd-analyze verifies the unit where systemd is there; a second install keeps an edited kilnd.conf.
# Usage: install_test.sh SOURCE_DIR BUILD_DIR   (CTest: install_prefix)
set -euo pipefail
src="$(cd "$1" && pwd)"
build="$(cd "$2" && pwd)"
work="$(mktemp -d "${TMPDIR:-/tmp}/kiln-install-test.XXXXXX")"
prefix="$work/prefix"
kilnd_pid=""
cleanup() {
  if [ -n "$kilnd_pid" ]; then kill -TERM "$kilnd_pid" 2>/dev/null && wait "$kilnd_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "install_test: FAILED: $*" >&2; [ -f "$work/kilnd.log" ] && tail -n 20 "$work/kilnd.log" >&2; exit 1; }
start=$(date +%s)
step() { echo "install_test: [$(( $(date +%s) - start )) s] $*"; }
# No test may lean on the developer's environment: the package must find everything itself.
unset KILN_PYTHON_PROTO PYTHONPATH KILN_SERVER KILN_TOKEN KILN_TOKEN_FILE KILN_TLS_CA OCIO PIP_FIND_LINKS PIP_INDEX_URL
cd "$work"

step "cmake --install into $prefix"
cmake --install "$build" --prefix "$prefix" > "$work/install.log" ||
  { cat "$work/install.log"; fail "cmake --install"; }
for f in bin/kilnd bin/kiln bin/kiln-brdf bin/kiln-sky etc/kiln/kilnd.conf lib/systemd/system/kilnd.service \
         share/kiln/ocio/config.ocio include/kiln/client/lib/client.h include/kiln/proto/kiln.pb.h \
         lib/cmake/kiln/kilnConfig.cmake lib/pkgconfig/kiln-client.pc lib/python3/dist-packages/kiln/kiln_pb2.py \
         share/doc/kiln-daemon/copyright; do
  [ -e "$prefix/$f" ] || fail "the install has no $f"
done
ls "$prefix"/share/kiln/examples/*.textproto > /dev/null || fail "the install has no example jobs"
# The wheel for machines without protoc must carry the protocol module the build generated, and python -m kiln.
/usr/bin/python3 - "$prefix"/share/kiln/python/kiln_client-*-py3-none-any.whl "$build/python/kiln/kiln_pb2.py" <<'PY' ||
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as wheel, open(sys.argv[2], "rb") as generated:
    assert wheel.read("kiln/kiln_pb2.py") == generated.read(), "its kiln_pb2.py is not the build's"
    assert "kiln/__main__.py" in wheel.namelist(), "it has no kiln/__main__.py"
PY
  fail "the installed wheel is not whole"
[ -n "$(find "$prefix" -name libkiln_client.a)" ] ||
  fail "the install has no libkiln_client.a"
if command -v help2man > /dev/null; then
  for p in kilnd kiln kiln-brdf kiln-sky; do [ -s "$prefix/share/man/man1/$p.1.gz" ] || fail "no man page for $p"; done
else
  echo "install_test: help2man is not installed, so no man pages were made (Debian package help2man)"
fi
# Text files must not name the source or build tree (the binaries are checked through running them below).
if grep -rIl -e "$src" -e "$build" "$prefix" --exclude-dir=bin --exclude='*.a' > "$work/leaks" 2>/dev/null; then
  fail "installed files name the source or build tree: $(tr '\n' ' ' < "$work/leaks")"
fi
unit="$prefix/lib/systemd/system/kilnd.service"
grep -q "^ExecStart=$prefix/bin/kilnd --config $prefix/etc/kiln/kilnd.conf$" "$unit" ||
  fail "the unit's ExecStart does not name the installed kilnd and config"
grep -q "^store: \"$prefix/var/lib/kiln\"$" "$prefix/etc/kiln/kilnd.conf" ||
  fail "kilnd.conf's store is not under the prefix"

step "starting the installed kilnd with the installed config"
token_file="$(sed -n 's/^token_file: "\(.*\)"$/\1/p' "$prefix/etc/kiln/kilnd.conf")"
[ "$token_file" = "$prefix/etc/kiln/tokens" ] || fail "kilnd.conf's token_file is $token_file, not under the prefix"
( umask 077; od -An -N32 -tx1 /dev/urandom | tr -d ' \n' > "$token_file"; echo >> "$token_file" )
# Run from the scratch folder, with nothing of the developer's environment (unset above) to lead it to the build.
"$prefix/bin/kilnd" --config "$prefix/etc/kiln/kilnd.conf" --listen 127.0.0.1:0 \
  > "$work/kilnd.out" 2> "$work/kilnd.log" &
kilnd_pid=$!
. "$src/deploy/kilnd_address.sh"
address=$(kilnd_address "$work/kilnd.out" "$kilnd_pid") || fail "the installed kilnd did not start (above)"
ls "$prefix/var/lib/kiln/"*.sqlite > /dev/null 2>&1 || fail "kilnd made no store under $prefix/var/lib/kiln"

step "baking the installed examples with the installed kiln"
# As shipped, with their quality loosened (at most 16 samples, a target error of 0.05): this test is about the install,
# and the glass example alone takes ~40 s at its own quality on the shared 2-core machine.
mkdir -p "$work/jobs"
examples=()
for job in "$prefix"/share/kiln/examples/*.textproto; do
  name="$(basename "$job" .textproto)"
  examples+=("$name")
  sed -e 's/^\( *\)samples: [0-9]*/\1samples: 16/' -e 's/^\( *\)target_error: [0-9.e-]*/\1target_error: 0.05/' \
    "$job" > "$work/jobs/$name.textproto"
  "$prefix/bin/kiln" --server "$address" --token-file "$token_file" submit "$work/jobs/$name.textproto" \
    --out "$work/cpp/$name" > "$work/kiln.out" 2> "$work/kiln.err" ||
    { cat "$work/kiln.err"; fail "kiln submit $name"; }
done

step "pip install client/python into a fresh virtual environment (--system-site-packages, --no-index)"
# A copy of the package and the proto it is generated from, in their places: pip builds in the source folder.
mkdir -p "$work/src/client" "$work/src/proto"
cp -r "$src/client/python" "$work/src/client/python"
rm -rf "$work/src/client/python/build" "$work/src/client/python/"*.egg-info "$work/src/client/python/kiln/kiln_pb2.py"
cp "$src/proto/kiln.proto" "$work/src/proto/"
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
"$work/venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-build-isolation --no-index \
  "$work/src/client/python" > "$work/pip.log" 2>&1 || { cat "$work/pip.log"; fail "pip install client/python"; }
rm -rf "$work/src"  # the installed package must not need its source either
"$work/venv/bin/python" - "$work/venv" <<'PY' || fail "the pip-installed kiln is not self-contained"
import os, sys
import kiln
venv = os.path.realpath(sys.argv[1])
for module in (kiln, kiln.pb):
    path = os.path.realpath(module.__file__)
    assert path.startswith(venv + os.sep), "%s loaded from %s, outside the venv" % (module.__name__, path)
print("install_test: kiln %s and its protocol module load from the virtual environment" % kiln.PROTOCOL_VERSION)
PY

step "the same examples through python -m kiln: identical outputs"
for name in "${examples[@]}"; do
  "$work/venv/bin/python" -m kiln --server "$address" --token-file "$token_file" submit \
    "$work/jobs/$name.textproto" --out "$work/py/$name" > /dev/null 2> "$work/py.err" ||
    { cat "$work/py.err"; fail "python -m kiln submit $name"; }
  for f in "$work/py/$name"/*; do
    cmp -s "$f" "$work/cpp/$name/$(basename "$f")" || fail "$name: $(basename "$f") differs between the clients"
  done
done
job_id="$("$work/venv/bin/python" -m kiln --server "$address" --token-file "$token_file" submit \
  "$work/jobs/${examples[0]}.textproto")"
"$work/venv/bin/python" -m kiln --server "$address" --token-file "$token_file" watch "$job_id" 2> /dev/null ||
  fail "python -m kiln watch $job_id"
"$work/venv/bin/python" -m kiln --server "$address" --token-file "$token_file" fetch "$job_id" --out "$work/fetched" \
  > /dev/null || fail "python -m kiln fetch $job_id"
[ -n "$(ls "$work/fetched")" ] || fail "python -m kiln fetch wrote nothing"

step "a program built against the install with find_package(kiln)"
cmake -S "$src/tests/install/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
  > "$work/consumer.log" 2>&1 && cmake --build "$work/consumer" >> "$work/consumer.log" 2>&1 ||
  { cat "$work/consumer.log"; fail "building against find_package(kiln)"; }
"$work/consumer/kiln_consumer" "$address" "$token_file" || fail "the find_package(kiln) program could not say hello"
pc="$(find "$prefix" -name kiln-client.pc | head -n 1)"
cflags="$(PKG_CONFIG_PATH="$(dirname "$pc")" pkg-config --cflags kiln-client)" || fail "pkg-config kiln-client"
inc="${cflags#-I}"
[ -f "${inc%% *}/client/lib/client.h" ] || fail "pkg-config kiln-client gives $cflags, without client/lib/client.h"

if command -v systemd-analyze > /dev/null; then
  step "systemd-analyze verify kilnd.service"
  # Any complaint about the unit is printed by verify, with or without a failing exit status: both fail the test.
  # verify also runs `man` on the unit's Documentation=man:kilnd(1): the installed page, where man is installed.
  man_check=(--man=no)
  if command -v man > /dev/null && [ -s "$prefix/share/man/man1/kilnd.1.gz" ]; then man_check=(--man=yes); fi
  MANPATH="$prefix/share/man" systemd-analyze verify "${man_check[@]}" "$unit" \
    > "$work/verify.log" 2>&1 ||
    { cat "$work/verify.log"; fail "systemd-analyze verify kilnd.service"; }
  if grep -q "kilnd.service" "$work/verify.log"; then cat "$work/verify.log"; fail "systemd-analyze verify"; fi
else
  echo "install_test: systemd-analyze is not installed (Debian package systemd): the unit is not verified here"
fi
step "installing again over an edited kilnd.conf keeps it and puts the new one beside it"
sed -i 's/^workers: 1$/workers: 3/' "$prefix/etc/kiln/kilnd.conf"
cmake --install "$build" --prefix "$prefix" > "$work/install2.log" ||
  { cat "$work/install2.log"; fail "the second cmake --install"; }
grep -q "^workers: 3$" "$prefix/etc/kiln/kilnd.conf" || fail "a second install replaced the edited kilnd.conf"
grep -q "^workers: 1$" "$prefix/etc/kiln/kilnd.conf.new" || fail "a second install left no kilnd.conf.new"
step "passed"
