#!/bin/sh
# The benchmark's setup line: Debian's Blender (whose Cycles is the baker compared), numpy and OpenImageIO's Python
# module (compare.py reads kiln's EXRs with them; /usr/bin/python3 runs it).
set -e
if [ "$(id -u)" -ne 0 ]; then sudo=sudo; else sudo=; fi
$sudo apt-get install -y blender python3-numpy python3-openimageio openimageio-tools
