#!/usr/bin/env bash
# Lists the longest functions of the product code (bakers/, daemon/, proto/, client/; tests and tools aside), with
# their length in lines, from universal-ctags' start and end lines.
#   tests/tools/longest_functions.sh [COUNT]      (COUNT defaults to 10)
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$top"
ctags -R --languages=C++ --kinds-C++=f --fields=+ne --output-format=json -f - bakers daemon proto client |
  /usr/bin/python3 -c '
import json, sys
rows = []
for line in sys.stdin:
    t = json.loads(line)
    if "end" in t and "/tools/" not in t["path"]:
        scope = t.get("scope", "")
        name = (scope + "::" if scope else "") + t["name"]
        rows.append((t["end"] - t["line"] + 1, name, "%s:%d" % (t["path"], t["line"])))
for n, name, where in sorted(rows, reverse=True)[: int(sys.argv[1])]:
    print("%5d  %-50s %s" % (n, name, where))
' "${1:-10}"
