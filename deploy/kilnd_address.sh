# Sourced by the scripts that start a kilnd on 127.0.0.1:0 and need the port it chose.
#
# kilnd_address OUT PID: waits up to 30 s for the kilnd with process id PID to write "kilnd: listening on ADDRESS"
# into OUT (its stdout) and prints ADDRESS. Returns 1, saying why on stderr, when kilnd exits first or does not
# listen in time.
kilnd_address() {
  local out="$1" pid="$2" address=""
  for _ in $(seq 1 300); do
    address=$(sed -n 's/^kilnd: listening on \(127\.0\.0\.1:[0-9]*\)$/\1/p' "$out")
    if [ -n "$address" ]; then
      echo "$address"
      return 0
    fi
    kill -0 "$pid" 2>/dev/null || { echo "kilnd exited before it listened" >&2; return 1; }
    sleep 0.1
  done
  echo "kilnd did not listen within 30 s" >&2
  return 1
}
