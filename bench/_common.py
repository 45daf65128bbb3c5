"""Helpers shared by the bench scripts: machine description, timing medians,
subprocess runs with their peak memory, the binary array files of the CGAL
programs, building bench/cgal and the C++ Delaunay driver, and the common
command-line options / markdown output of the per-benchmark tables.

The scripts import it as a sibling (``from _common import ...``; Python puts
the script's folder first on sys.path), and so can tests that put bench/ on
sys.path (tests/test_compare.py does).
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, Iterable, List, Optional, Sequence, Tuple

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CGAL_SRC = ROOT / "bench" / "cgal"


def use_dev_build() -> None:
    """With FAULTMESH_DEV_BUILD=build/<dir> set, make ``import faultmesh`` load
    the package in python/ (which then loads that build's extension) rather
    than an installed one."""
    if os.environ.get("FAULTMESH_DEV_BUILD") and str(ROOT / "python") not in sys.path:
        sys.path.insert(0, str(ROOT / "python"))


# ---------------------------------------------------------------- machine

def cpu_name() -> str:
    cpu = platform.processor() or platform.machine() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return cpu


def compiler_version() -> str:
    r = subprocess.run([os.environ.get("CXX", "g++"), "--version"], capture_output=True, text=True)
    return (r.stdout.splitlines() or ["unknown compiler"])[0]


def cgal_version() -> str:
    try:
        txt = Path("/usr/include/CGAL/version.h").read_text()
    except OSError:
        return "CGAL ?"
    m = re.search(r'#define CGAL_VERSION_STR CGAL_STR\(([^)]*)\)', txt) or \
        re.search(r'#define CGAL_VERSION (\S+)', txt)
    return "CGAL " + m.group(1) if m else "CGAL ?"


def machine(*, compiler: bool = False, cgal: bool = False, python: bool = True, numpy: bool = False,
            faultmesh: bool = False) -> str:
    """One line naming the machine and the software a table was made with."""
    parts = [cpu_name(), f"{os.cpu_count()} logical cores", f"{platform.system()} {platform.release()}"]
    if compiler:
        parts.append(compiler_version())
    if cgal:
        parts.append(cgal_version())
    if python:
        parts.append(f"Python {platform.python_version()}")
    if numpy:
        parts.append(f"numpy {np.__version__}")
    if faultmesh:
        import faultmesh as fm
        parts.append(f"faultmesh {fm.__version__}")
    return ", ".join(parts)


# ----------------------------------------------------------------- timing

def time_runs(fn: Callable[[], object], runs: int) -> List[float]:
    """Wall-clock seconds of ``runs`` calls of fn."""
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def median_time(fn: Callable[[], object], runs: int) -> float:
    return statistics.median(time_runs(fn, runs))


def proc_status_mib(key: str) -> float:
    """A memory figure of /proc/self/status (VmRSS, VmHWM, ...) in MiB, nan
    where unavailable."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def reset_peak_rss() -> bool:
    """Reset this process's VmHWM to its current RSS (Linux >= 4.0: write 5 to
    /proc/self/clear_refs). False where that is not possible."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


# ------------------------------------------------------------- subprocesses

def run_program(cmd: Sequence[object]) -> Tuple[dict, float]:
    """Run one bench program; returns (the JSON of its last stdout line, its
    peak resident memory in MiB).

    The peak is the VmHWM the program reads from /proc/self/status at its end
    (its "peak_rss_kib"). The ru_maxrss that os.wait4 returns is only a
    fallback: Linux carries the parent's high-water mark over fork + exec, so
    for a child of this Python process it is at least this process's size
    (a 21k-point Delaunay run "peaked" at 394 MiB that way)."""
    cmd = [str(c) for c in cmd]
    # stderr goes to a file so that neither pipe can fill up and block the child.
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err)
        stdout = proc.stdout.read()
        _, status, usage = os.wait4(proc.pid, 0)  # reaps the child, with its resource usage
        proc.stdout.close()
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            raise RuntimeError(f"{Path(cmd[0]).name} failed (exit {proc.returncode}): {' '.join(cmd[1:])}\n"
                               f"{err.read().decode(errors='replace')}")
    j = json.loads(stdout.decode().strip().splitlines()[-1])
    kib = j.get("peak_rss_kib", -1)
    return j, (kib if kib > 0 else usage.ru_maxrss) / 1024.0


def write_array(path: Path, a: np.ndarray, dtype: str) -> None:
    """The array files of the CGAL programs: int64 row count, then the rows
    (little-endian ``dtype``, "<f8" or "<i8")."""
    a = np.ascontiguousarray(a, dtype=dtype)
    with open(path, "wb") as f:
        f.write(np.int64(len(a)).astype("<i8").tobytes())
        f.write(a.tobytes())


# ------------------------------------------------------------------ builds

def _generator() -> List[str]:
    return ["-G", "Ninja"] if shutil.which("ninja") else []


def build_cgal(targets: Iterable[str], build_dir: Optional[Path] = None) -> Path:
    """Configure and build bench/cgal (Release) and the given programs; returns
    the build folder. Default folder: $FAULTMESH_CGAL_BUILD or build/cgal."""
    build = Path(build_dir if build_dir is not None else
                 os.environ.get("FAULTMESH_CGAL_BUILD", ROOT / "build" / "cgal"))
    # An existing build folder keeps its generator (CMake refuses to switch).
    gen = [] if (build / "CMakeCache.txt").is_file() else _generator()
    for cmd in (["cmake", "-S", str(CGAL_SRC), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release", *gen],
                ["cmake", "--build", str(build), "-j2", "--target", *targets]):
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"building bench/cgal failed: {' '.join(cmd)}\n"
                               f"{r.stdout[-2000:]}{r.stderr[-2000:]}")
    for t in targets:
        if not (build / t).is_file():
            raise FileNotFoundError(f"CGAL program {t} was not built in {build}")
    return build


def cgal_program(name: str, build_dir: Optional[Path] = None) -> Path:
    """Path of one bench/cgal program, built if needed."""
    return build_cgal([name], build_dir) / name


def build_delaunay_driver(build_dir: Path) -> Path:
    """bench/delaunay_driver.cpp compiled against the library sources with
    -O3 -DNDEBUG (a CMake Release build's flags)."""
    build_dir.mkdir(parents=True, exist_ok=True)
    driver = build_dir / "delaunay_driver"
    srcs = [ROOT / "bench" / "delaunay_driver.cpp", ROOT / "cpp" / "src" / "delaunay.cpp",
            ROOT / "cpp" / "src" / "predicates.cpp"]
    subprocess.run([os.environ.get("CXX", "g++"), "-O3", "-DNDEBUG", "-std=c++17", "-ffp-contract=off",
                    "-I", str(ROOT / "cpp" / "include"), "-I", str(ROOT / "cpp" / "src"),
                    "-I", str(CGAL_SRC), *map(str, srcs), "-o", str(driver)], check=True)
    return driver


# ----------------------------------------------------- command line, output

def add_table_args(ap: argparse.ArgumentParser, doc: str) -> None:
    """--runs, --only and --no-write of the scripts that write docs/bench/<doc>.md."""
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", nargs="*", help="substrings of dataset names to run")
    ap.add_argument("--no-write", action="store_true", help=f"do not write docs/bench/{doc}.md")


def parse_table_args(ap: argparse.ArgumentParser) -> argparse.Namespace:
    args = ap.parse_args()
    if args.runs < 1:
        ap.error("--runs must be >= 1")
    return args


def selected(name: str, only: Optional[Sequence[str]]) -> bool:
    return not only or any(s in name for s in only)


def pick(datasets: Sequence[Tuple[str, Callable]],
         only: Optional[Sequence[str]]) -> List[Tuple[str, Callable]]:
    """The (name, maker) pairs whose name contains one of the --only substrings
    (all without --only)."""
    return [(name, make) for name, make in datasets if selected(name, only)]


def command_line(script: str, argv: Optional[Sequence[str]] = None,
                 drop: Sequence[str] = ("--no-write",)) -> str:
    """The command that reproduces a table (without the options that only
    decide where it goes)."""
    argv = sys.argv[1:] if argv is None else argv
    return f"python bench/{script}" + "".join(f" {shlex.quote(a)}" for a in argv if a not in drop)


def today() -> str:
    return datetime.date.today().isoformat()


def table_header(title: str, script: str, machine_line: str) -> List[str]:
    """First lines of a docs/bench table: its title, the command that
    reproduces it, the date and the machine."""
    return [f"## {title}", "", f"Command: `{command_line(script)}`  ", f"Date: {today()}  ",
            f"Machine: {machine_line}  "]


def write_table(text: str, doc: str, args: argparse.Namespace) -> None:
    """Print a table; write it to docs/bench/<doc>.md unless --no-write or a
    subset (--only) was run."""
    print(text)
    if not args.no_write and not args.only:
        out = ROOT / "docs" / "bench" / f"{doc}.md"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text)
        print(f"wrote {out.relative_to(ROOT)}", file=sys.stderr)
