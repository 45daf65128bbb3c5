"""Assemble docs/benchmarks.md from the per-benchmark tables in docs/bench/.

Each bench script writes its own table (with machine, command and date) to
docs/bench/<name>.md; this script concatenates them in a fixed order so the
README can link one page.
"""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ORDER = ["delaunay", "polygon", "aabb", "boundary", "compare", "scale", "model", "ensemble", "derive", "sweep"]


def main() -> None:
    parts = sorted((ROOT / "docs" / "bench").glob("*.md"),
                   key=lambda p: (ORDER.index(p.stem) if p.stem in ORDER else len(ORDER), p.stem))
    out = ["# faultmesh benchmarks", "",
           "Every table below was produced by the command shown with it, on the machine",
           "named with it; times are medians over repeated runs and ratios are against the",
           "reference run in the same session. Regenerate a table by re-running its command,",
           "then `python bench/collect_docs.py`.", ""]
    for p in parts:
        out += [p.read_text().rstrip(), ""]
    (ROOT / "docs" / "benchmarks.md").write_text("\n".join(out))
    print(f"wrote docs/benchmarks.md from {len(parts)} tables")


if __name__ == "__main__":
    main()
