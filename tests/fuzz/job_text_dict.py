#!/usr/bin/env python3
"""The job_text fuzz target's dictionary (tests/fuzz/dict/job_text.dict): every field and enum value name of
proto/kiln.proto, then the text format's tokens. A dictionary that lacks a name makes the fuzzer find that field
only by chance, so CTest's fuzz_dict_job_text fails when kiln.proto gains a name the file does not hold.

Usage: job_text_dict.py --write   rewrite the dictionary from kiln.proto
       job_text_dict.py --check   exit 1, naming what is missing or stale, unless the file is what --write makes
"""
import pathlib
import re
import sys

TOP = pathlib.Path(__file__).resolve().parents[2]
PROTO = TOP / "proto" / "kiln.proto"
DICT = TOP / "tests" / "fuzz" / "dict" / "job_text.dict"
HEADER = "# kiln.proto's field and enum value names (tests/fuzz/job_text_dict.py --write), and text-format tokens."
TOKENS = ['{', '}', ':', '[', ']', '<', '>', '#', '\\"', 'inf', 'nan', '-1e308', '0x', 'true', 'false', 'key:',
          'value:']


def proto_names(text):
    text = re.sub(r"//[^\n]*", "", text)
    fields = re.findall(r"^\s*(?:optional |repeated )?(?:map<[^>]+>|[\w.]+) (\w+) = \d+", text, re.M)
    values = re.findall(r"^\s*([A-Z][A-Z0-9_]*) = -?\d+", text, re.M)
    return sorted(set(fields) | set(values))


def dictionary():
    names = proto_names(PROTO.read_text())
    return "\n".join([HEADER] + [f'"{n}"' for n in names] + [f'"{t}"' for t in TOKENS]) + "\n"


def main(argv):
    if argv[1:] == ["--write"]:
        DICT.write_text(dictionary())
        return 0
    if argv[1:] == ["--check"]:
        want, have = dictionary(), DICT.read_text()
        if want == have:
            return 0
        missing = sorted(set(want.splitlines()) - set(have.splitlines()))
        stale = sorted(set(have.splitlines()) - set(want.splitlines()))
        print(f"{DICT.relative_to(TOP)} is out of date with {PROTO.relative_to(TOP)}: missing {missing}, stale "
              f"{stale}; run tests/fuzz/job_text_dict.py --write")
        return 1
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
