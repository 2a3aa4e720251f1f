"""Evaluation runs that also measure the learnt range law (issue 13's "Must show").

    nice -n 10 python tools/range_law_runs.py missions/slalom.yaml --seeds 0 20 \
        --set camera.learn_range=true --set camera.range.a=44814 --out low.jsonl

Each run is exactly ``marknav evaluate``'s run of that seed (the same generated, randomised
world; ``--set`` as there), and success is decided the same way (the tree completed the route
and the simulator's ground truth confirms every pass). For each run it also compares the law in
use when each waypoint was passed (the report's ``range_law.at``) with the simulated camera's
own law, at 0.6, 1, 1.5 and 2 m. One JSON line per run goes to ``--out`` as it finishes (a
long batch can be stopped and resumed with another ``--seeds`` range); the summary prints the
success rate with its Wilson interval and the median |error| at each waypoint. Not part of CI.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

DISTANCES_MM = (600.0, 1000.0, 1500.0, 2000.0)


def run(mission_path: str, seed: int, overrides: list[str]) -> dict[str, object]:
    from marknav.missions.overrides import parse_overrides
    from marknav.missions.schema import load_mission
    from marknav.runs.evaluation.job import _quiet_runs
    from marknav.runs.loop.run import RunRequest, execute
    from marknav.runs.records.seed_result import SeedResult
    from marknav.sim.camera_model import sim_range_law
    from marknav.vision.estimate import PowerLaw

    mission = load_mission(mission_path, overrides=parse_overrides(overrides))
    req = RunRequest(mission=mission, seed=seed, generate_world=True, randomise=True)
    with _quiet_runs():
        report = execute(req).report
    result = SeedResult.from_report(seed, report, mission=mission_path,
                                    clearance_mm=mission.navigation.clearance_mm)
    a, b = sim_range_law(mission.camera.focal_px, mission.marks.radius_mm)
    true = PowerLaw(a=a, b=b)
    errors: list[list[float] | None] = []
    law = report.range_law or {}
    for used in law.get("at", []) or []:
        if used is None:
            errors.append(None)
            continue
        learnt = PowerLaw(a=used["a"], b=used["b"])
        errors.append([round(learnt.distance_mm(true.radius_px(d)) / d - 1.0, 4)
                       for d in DISTANCES_MM])
    return {"seed": seed, "success": result.success,
            "reason": None if result.success else result.failure_reason,
            "collisions": result.collisions, "errors_at_waypoints": errors,
            "final": {k: law.get(k) for k in ("a", "b", "steps", "rejected")}}


def summary(rows: list[dict[str, object]]) -> str:
    from marknav.runs.evaluation.evaluate import wilson_interval

    n = len(rows)
    k = sum(1 for r in rows if r["success"])
    lo, hi = wilson_interval(k, n)
    out = [f"success {k}/{n} = {100.0 * k / max(n, 1):.1f} % (95 % CI {100 * lo:.1f}-"
           f"{100 * hi:.1f} %)"]
    for r in rows:
        if not r["success"]:
            out.append(f"  seed {r['seed']}: {r['reason']}")
    for w in range(2):
        per_d = []
        for j, d in enumerate(DISTANCES_MM):
            vals = [abs(e[w][j]) for r in rows
                    if len(e := r["errors_at_waypoints"]) > w and e[w] is not None]  # type: ignore[arg-type]
            if vals:
                per_d.append(f"{d / 1000:g} m {100 * statistics.median(vals):.1f} %")
        if per_d:
            out.append(f"median |error| of the law in use when waypoint {w + 1} was passed: "
                       + ", ".join(per_d) + f" ({len(vals)} runs)")
    return "\n".join(out)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("mission")
    p.add_argument("--seeds", nargs=2, type=int, metavar=("FIRST", "STOP"), required=True)
    p.add_argument("--set", action="append", default=[], dest="overrides")
    p.add_argument("--out", type=Path, required=True, help="JSON lines, appended")
    p.add_argument("--summary", action="store_true", help="only summarise --out")
    args = p.parse_args()
    if not args.summary:
        for seed in range(*args.seeds):
            row = run(args.mission, seed, args.overrides)
            with args.out.open("a", encoding="utf-8") as f:
                f.write(json.dumps(row) + "\n")
            print(f"seed {seed}: {'ok' if row['success'] else row['reason']}", flush=True)
    rows = [json.loads(line) for line in args.out.read_text(encoding="utf-8").splitlines()
            if line.strip()]
    print(summary(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
