#!/usr/bin/env bash
# The whole test suite on a fresh machine: installs what it needs (Debian
# packages when run as root, the package itself with its test extras), then
# runs the C++ tests (ctest) and the Python tests (pytest). Exits non-zero on
# any failure or if either runner executed no test.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"

# libgl1/libegl1: VTK (pyvista) renders off screen in the interactive-view test
need=(cmake g++ ninja-build libcgal-dev libgtest-dev libgl1 libegl1)
missing=()
for p in "${need[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
  else
    sudo apt-get update -qq
    sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
  fi
fi

# The package's wheel is built with the C++ tests (FAULTMESH_BUILD_TESTS) in
# build/wheel-tests, so that ctest runs on the same Release build of the
# library as the Python module: one compile of the library instead of two.
python3 -m pip install --quiet -C build-dir=build/wheel-tests \
  -C cmake.define.FAULTMESH_BUILD_TESTS=ON ".[test]"
# geoh5py pins exact minors of numpy/Pillow/pydantic (pyproject.toml, test
# extra); it runs with the versions above, so it comes without its pins.
python3 -m pip install --quiet --no-deps "geoh5py==0.12.2"

echo "== C++ tests (ctest)"
ctest --test-dir build/wheel-tests --output-on-failure -j2 --no-tests=error

echo "== C++ tests under AddressSanitizer + UndefinedBehaviorSanitizer (ctest)"
# A second build of the library and the C++ tests with sanitizers (CMake
# option FAULTMESH_SANITIZE); every finding aborts its test. At -O1 (as
# AddressSanitizer's documentation advises; with frame pointers): 108 s of build and 20 s
# of tests on two cores, against 152 s and 20 s at RelWithDebInfo's -O2.
cmake -S . -B build/asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" \
  -DFAULTMESH_BUILD_TESTS=ON -DFAULTMESH_BUILD_PYTHON=OFF \
  -DFAULTMESH_SANITIZE=address,undefined >/dev/null
cmake --build build/asan -j2
ASAN_OPTIONS=detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1 \
UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build/asan --output-on-failure -j2 --no-tests=error

echo "== Python tests (pytest)"
# Run from tests/ against the installed package (not the source tree), in two
# processes (pytest-xdist, one per core of the CI machine); --dist loadgroup
# shares the tests out between them as they finish, except that those with
# the same xdist_group mark (the Dask cluster's in test_ensemble.py) run in
# one process, on one cluster.
python3 -m pytest -p no:cacheprovider -q -n 2 --dist loadgroup "$here/tests" "$@"
