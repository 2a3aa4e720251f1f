"""Session 5 notes: ``marknav bench loop``'s figures for several commits in one sitting.

Usage (from the project root, with the project's venv active)::

    python docs/notes/2026-12-02/loop-by-commit.py 8504aca b5049c1 HEAD

Each commit's ``marknav`` and ``missions`` are exported (``git archive``) to a temporary folder
and the benchmark runs in a fresh interpreter with that folder first on ``sys.path`` (the
editable install would otherwise win over ``PYTHONPATH``). ``missions/`` matters: without it
``bench_loop`` falls back to a plainer slalom (36.6 s simulated instead of 40.8 s).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

RUN = """
import json, sys
sys.path.insert(0, sys.argv[1])
import marknav
assert marknav.__file__.startswith(sys.argv[1]), marknav.__file__
from marknav.runs.bench import bench_loop
loop = bench_loop()
print(json.dumps({k: loop[k] for k in ("speedup", "sim_time_s", "cycles",
                                       "breakdown_ms_per_cycle")}))
"""


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        for commit in sys.argv[1:]:  # a commit named twice runs twice (interleaved rounds)
            root = Path(tmp) / commit
            if not root.exists():
                root.mkdir()
                archive = subprocess.run(["git", "archive", commit, "marknav", "missions"],
                                         check=True, capture_output=True).stdout
                subprocess.run(["tar", "-x", "-C", str(root)], input=archive, check=True)
            out = subprocess.run([sys.executable, "-c", RUN, str(root)], check=True,
                                 capture_output=True, text=True, cwd=tmp).stdout
            print(commit, json.dumps(json.loads(out.strip().splitlines()[-1])))


if __name__ == "__main__":
    main()
