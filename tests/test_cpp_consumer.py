"""The wheel is also the C++ SDK: a downstream CMake project finds and links it."""
import shutil
import subprocess
from pathlib import Path

import numpy as np

import faultmesh

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "cpp_consumer"


def test_cmake_dir_has_config():
    d = Path(faultmesh.cmake_dir())
    assert (d / "faultmeshConfig.cmake").is_file()
    assert (Path(faultmesh.include_dir()) / "faultmesh" / "delaunay.hpp").is_file()


def test_downstream_project_builds_and_triangulates(tmp_path):
    build = tmp_path / "build"
    gen = ["-G", "Ninja"] if shutil.which("ninja") else []
    subprocess.run(["cmake", "-S", str(EXAMPLE), "-B", str(build), *gen,
                    f"-DCMAKE_PREFIX_PATH={faultmesh.cmake_dir()}"], check=True,
                   capture_output=True, text=True)
    subprocess.run(["cmake", "--build", str(build)], check=True, capture_output=True, text=True)
    exe = build / "triangulate"

    rng = np.random.default_rng(7)
    pts = rng.random((200, 2))
    f = tmp_path / "pts.txt"
    np.savetxt(f, pts, fmt="%.17g")
    out = subprocess.run([str(exe), str(f)], check=True, capture_output=True, text=True).stdout
    lines = out.strip().splitlines()
    assert lines[0].startswith("triangles ")
    tris = np.array([list(map(int, s.split())) for s in lines[1:]])
    assert len(tris) == int(lines[0].split()[1])
    # The C++ library and the Python module are the same code: same triangles.
    norm = lambda t: {tuple(np.roll(r, -int(np.argmin(r)))) for r in t}  # noqa: E731
    assert norm(tris) == norm(faultmesh.delaunay(pts))
