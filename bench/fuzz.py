"""Run the fuzz targets (tests marked ``fuzz``) for longer than CI does.

    python bench/fuzz.py [--examples N] [--seed S] [-k EXPR] [pytest args...]

CI runs each target with a small, derandomized number of examples (see
``tests/helpers.py: fuzz_settings``). Here every target gets ``--examples``
examples (default 20000) from a random seed, printed first so that a failure
can be replayed with ``--seed``. Exit status is pytest's.
"""
from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--examples", type=int, default=20000, help="examples per target")
    ap.add_argument("--seed", type=int, default=None, help="hypothesis seed (default: random)")
    ap.add_argument("-k", default=None, help="pytest -k expression selecting targets")
    args, rest = ap.parse_known_args(argv)
    seed = args.seed if args.seed is not None else random.SystemRandom().randrange(2 ** 32)
    print(f"fuzz: {args.examples} examples per target, seed {seed}", flush=True)
    env = dict(os.environ, FAULTMESH_FUZZ_EXAMPLES=str(args.examples))
    cmd = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", "-m", "fuzz",
           f"--hypothesis-seed={seed}", str(ROOT / "tests")]
    if args.k:
        cmd += ["-k", args.k]
    return subprocess.call(cmd + rest, env=env)


if __name__ == "__main__":
    sys.exit(main())
