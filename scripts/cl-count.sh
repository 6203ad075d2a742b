#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs a command with the OpenCL call counter (scripts/cl-count.c) preloaded; the counts go to
# stderr when the command exits. Example:
#   scripts/cl-count.sh build/bin/terracl bench edit --size 1025 --repeats 1
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
lib=${CL_COUNT_LIB:-/tmp/terracl-cl-count.so}
if [[ ! -f $lib || $here/cl-count.c -nt $lib ]]; then
  cc -O2 -shared -fPIC -o "$lib" "$here/cl-count.c" -ldl
fi
LD_PRELOAD=$lib exec "$@"
