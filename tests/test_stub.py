"""The type stub of the extension module (python/faultmesh/_core.pyi) says
what the module has: every public function, class, method and property, and
a type checker accepts code that uses the kernels. Regenerate it with
scripts/gen-stub.sh after changing a binding."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import faultmesh
from faultmesh import _core

STUB = Path(faultmesh.__file__).resolve().parent / "_core.pyi"
if not STUB.is_file():  # a development build runs the package from the source tree
    STUB = Path(__file__).resolve().parents[1] / "python" / "faultmesh" / "_core.pyi"


def _stub_names():
    tree = ast.parse(STUB.read_text())
    top, members = set(), {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            top.add(node.name)
            names = set()
            for n in node.body:
                if isinstance(n, (ast.FunctionDef, ast.ClassDef)):
                    names.add(n.name)
                elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name):
                    names.add(n.target.id)
                elif isinstance(n, ast.Assign):
                    names |= {t.id for t in n.targets if isinstance(t, ast.Name)}
            members[node.name] = names
        elif isinstance(node, ast.FunctionDef):
            top.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for t in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                if isinstance(t, ast.Name):
                    top.add(t.id)
    return top, members


def test_the_stub_lists_every_public_name_of_the_module():
    top, members = _stub_names()
    public = {n for n in dir(_core) if not n.startswith("_")}
    assert public - top == set(), f"in _core but not in _core.pyi (run scripts/gen-stub.sh): {public - top}"
    extra = {n for n in top - public if not n.startswith("__")}
    assert not extra, f"in _core.pyi but not in _core: {extra}"
    for cls, names in members.items():
        obj = getattr(_core, cls)
        have = {n for n in dir(obj) if not n.startswith("_")}
        missing = have - names - set(dir(type)) - set(dir(int)) - set(dir(ValueError))
        assert not missing, f"{cls}: not in _core.pyi: {missing}"


def test_a_type_checker_accepts_code_using_the_kernels(tmp_path):
    code = tmp_path / "use.py"
    code.write_text(
        "import numpy as np\n"
        "import faultmesh\n"
        "xy = np.zeros((10, 2))\n"
        "tri = faultmesh.delaunay(xy)\n"
        "tin = faultmesh.Tin(np.zeros((10, 3)))\n"
        "z = tin.interpolate(xy)\n"
        "area = faultmesh.StudyArea(xy[:4])\n"
        "inside = area.contains(xy)\n"
        "kind: faultmesh.TriangleKind = faultmesh.TriangleKind.gap\n")
    stubdir = STUB.parent.parent
    r = subprocess.run([sys.executable, "-m", "mypy", "--ignore-missing-imports", "--follow-imports=silent",
                        "--no-error-summary", str(code)],
                       capture_output=True, text=True, cwd=tmp_path,
                       env={"MYPYPATH": str(stubdir), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stdout + r.stderr
    bad = tmp_path / "bad.py"
    bad.write_text("import faultmesh\nfaultmesh.delaunay(1, 2, 3, 4)\n")
    r = subprocess.run([sys.executable, "-m", "mypy", "--ignore-missing-imports", "--follow-imports=silent",
                        str(bad)], capture_output=True, text=True, cwd=tmp_path,
                       env={"MYPYPATH": str(stubdir), "PATH": "/usr/bin:/bin"})
    assert r.returncode != 0 and "delaunay" in r.stdout, r.stdout
