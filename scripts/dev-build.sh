#!/usr/bin/env bash
# Developer build: C++ library, C++ tests and the Python module in one CMake
# build directory (default build/dev). Then run Python against it with
#   FAULTMESH_DEV_BUILD=$PWD/build/dev PYTHONPATH=$PWD/python python -m pytest
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dir=${1:-$here/build/dev}
cmake -S "$here" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DFAULTMESH_BUILD_TESTS=ON -DFAULTMESH_BUILD_PYTHON=ON >/dev/null
cmake --build "$dir" -j2
