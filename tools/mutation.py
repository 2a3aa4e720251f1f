"""Mutation testing of the modules where a silent bug is dangerous, one module at a time.

    nice -n 10 python tools/mutation.py safety          # one module (see MODULES)
    nice -n 10 python tools/mutation.py driver --only 'marknav.robot.driver.xǁCreateDriverǁclose*'
                                                        # only these mutants (fnmatch patterns)
    nice -n 10 python tools/mutation.py --all           # every module, smallest first
    python tools/mutation.py safety --report            # score + survivors of the last run

Each module runs in its own copy of the checkout (``.mutation/<module>/``, git-ignored) with the
``[tool.mutmut]`` table of pyproject.toml narrowed to that module's file and its tests, so a
module's run only executes the tests written for it and keeps its own cache (a second run only
re-checks what changed). The report lists every surviving mutant as a one-line diff;
docs/mutation.md records the scores and why each remaining survivor is harmless. Needs
``pip install -e ".[mutation]"`` (mutmut 3). Not part of CI: a full run takes tens of minutes.
"""

from __future__ import annotations

import argparse
import ast
import difflib
import json
import os
import shutil
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WORK = ROOT / ".mutation"


@dataclass(frozen=True)
class Module:
    path: str
    tests: tuple[str, ...]
    #: mutant name patterns (mutmut's ``module.x_function`` / ``module.xǁClassǁmethod``);
    #: empty: the whole file
    only: tuple[str, ...] = ()


MODULES: dict[str, Module] = {
    "search": Module("marknav/behaviours/search.py", (
        "tests/behaviours/test_search.py", "tests/behaviours/test_search_edges.py",
        "tests/behaviours/test_route.py")),
    "target": Module("marknav/behaviours/target.py", (
        "tests/behaviours/test_target.py", "tests/behaviours/test_target_edges.py",
        "tests/behaviours/test_association_gate.py", "tests/behaviours/test_perception.py",
        "tests/behaviours/test_route.py")),
    "bypass": Module("marknav/behaviours/bypass.py", (
        "tests/behaviours/test_bypass.py", "tests/behaviours/test_bypass_edges.py",
        "tests/behaviours/test_route.py")),
    "oi": Module("marknav/robot/oi.py", (
        "tests/robot/test_oi.py", "tests/robot/test_oi_edges.py",
        "tests/robot/test_oi_stream.py", "tests/robot/test_driver.py")),
    "driver": Module("marknav/robot/driver.py", (
        "tests/robot/test_driver.py", "tests/robot/test_driver_lifecycle.py",
        "tests/robot/test_odometry.py")),
    "safety": Module("marknav/robot/safety.py", (
        "tests/robot/test_safety.py", "tests/behaviours/test_safety.py",
        "tests/testing/test_fake_robot.py", "tests/robot/test_driver.py")),
    # the ground truth per waypoint, from the true path alone
    "truth": Module("marknav/runs/metrics/truth.py", (
        "tests/runs/metrics/test_truth.py", "tests/runs/metrics/test_truth_edges.py")),
    # the evaluation's verdict of one run (not the run itself)
    "verdict": Module("marknav/runs/evaluation/job.py", (
        "tests/runs/evaluation/test_evaluate.py", "tests/runs/metrics/test_verdict_edges.py",
        "tests/missions/test_truth_runs.py"),
        only=("marknav.runs.evaluation.job.xǁSeedResultǁ*",)),
    # the evaluation's statistics over the runs (not its text)
    "statistics": Module("marknav/runs/metrics/statistics.py", (
        "tests/runs/evaluation/test_evaluate.py", "tests/runs/metrics/test_verdict_edges.py",
        "tests/missions/test_truth_runs.py"),
        only=("marknav.runs.metrics.statistics.x_summarise*",
              "marknav.runs.metrics.statistics.x_wilson_interval*",
              "marknav.runs.metrics.statistics.x_percentile*",
              "marknav.runs.metrics.statistics.x__incident*")),
}

#: Tests that measure wall-clock margins or spawn processes are never selected: a mutant runs
#: several times slower under mutmut's trampolines.
DESELECT = "not real_time"


def config(module: Module) -> str:
    tests = ", ".join(f'"{t}"' for t in module.tests if (ROOT / t).exists())
    return (
        "[tool.mutmut]\n"
        'source_paths = ["marknav"]\n'
        # the run tests read the packaged missions (relative to the checkout)
        'also_copy = ["missions"]\n'
        f'only_mutate = ["{module.path}"]\n'
        f"pytest_add_cli_args_test_selection = [{tests}]\n"
        f'pytest_add_cli_args = ["-p", "no:cacheprovider", "-k", "{DESELECT}"]\n'
    )


def with_config(pyproject: str, table: str) -> str:
    """``pyproject`` with its ``[tool.mutmut]`` table replaced by ``table``."""
    out: list[str] = []
    skipping = False
    for line in pyproject.splitlines(keepends=True):
        if line.startswith("["):
            skipping = line.strip() == "[tool.mutmut]"
        if not skipping:
            out.append(line)
    return "".join(out).rstrip("\n") + "\n\n" + table


def prepare(name: str, module: Module) -> Path:
    """``.mutation/<name>/``: the checkout's tracked files (plus uncommitted edits), with the
    module's mutmut table. Files that did not change keep their timestamps, so mutmut's cache
    stays valid between runs."""
    work = WORK / name
    try:
        files = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"],
                               cwd=ROOT, check=True, capture_output=True, text=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):  # not a git checkout (an exported tree)
        files = [str(p.relative_to(ROOT)) for d in ("marknav", "tests", "missions")
                 for p in (ROOT / d).rglob("*") if "__pycache__" not in p.parts]
    for rel in files:
        if not (rel.startswith(("marknav/", "tests/", "missions/")) or rel == "README.md"):
            continue
        src, dst = ROOT / rel, work / rel
        if not src.is_file():
            continue
        if dst.exists() and dst.read_bytes() == src.read_bytes():
            continue
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    text = with_config((ROOT / "pyproject.toml").read_text("utf-8"), config(module))
    target = work / "pyproject.toml"
    if not target.exists() or target.read_text("utf-8") != text:
        target.write_text(text, "utf-8")
    return work


def run(name: str, module: Module, children: int) -> int:
    """Check the mutants not checked yet, then re-check the survivors (and the untested) of
    earlier runs (mutmut keeps a verdict until asked again by name, and the tests may have
    changed since). With name
    patterns (``only``), check exactly the mutants they match."""
    work = prepare(name, module)
    env = {**os.environ, "PY_TREES_DISABLE_COLORS": "1"}
    mutmut = shutil.which("mutmut") or str(Path(sys.executable).with_name("mutmut"))
    base = [mutmut, "run", "--max-children", str(children)]
    meta = work / "mutants" / (module.path + ".meta")
    earlier = _survivor_keys(meta, module) if meta.exists() else []
    rc = 0
    with open(work / "mutmut.log", "w", encoding="utf-8") as log:
        passes = [list(module.only)]
        if earlier and not module.only:  # with name patterns the first pass re-checks them all
            passes.append(earlier)
        for names in passes:
            cmd = [*base, *names]
            print(f"[{name}] {' '.join(cmd[:6])}{' …' if len(cmd) > 6 else ''}  (in {work})",
                  flush=True)
            rc = subprocess.run(cmd, cwd=work, env=env, stdout=log,
                                stderr=subprocess.STDOUT).returncode or rc
    return rc


def _survivor_keys(meta: Path, module: Module) -> list[str]:
    from fnmatch import fnmatchcase

    codes: dict[str, int | None] = json.loads(meta.read_text("utf-8"))["exit_code_by_key"]
    # survived (0), or no test called it (5, 33): a new test may kill it now
    return [k for k, c in codes.items() if c in (0, 5, 33)
            and (not module.only or any(fnmatchcase(k, p) for p in module.only))]


def _functions(source: str) -> dict[str, str]:
    """Source of every mutant (and ``__mutmut_orig``) function, by name."""
    lines = source.splitlines()
    return {n.name: "\n".join(lines[n.lineno - 1:n.end_lineno])
            for n in ast.walk(ast.parse(source))
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef) and "__mutmut_" in n.name}


def report(name: str, module: Module) -> dict[str, object]:
    from fnmatch import fnmatchcase

    from mutmut.stats import status_by_exit_code

    mutants = WORK / name / "mutants"
    meta = json.loads((mutants / (module.path + ".meta")).read_text("utf-8"))
    codes: dict[str, int | None] = meta["exit_code_by_key"]
    if module.only:
        codes = {k: v for k, v in codes.items() if any(fnmatchcase(k, p) for p in module.only)}
    status = Counter(status_by_exit_code[c] for c in codes.values())
    killed = sum(n for s, n in status.items() if s in ("killed", "timeout", "segfault",
                                                      "caught by type check"))
    judged = sum(n for s, n in status.items() if s != "not checked")
    survivors = sorted((k for k, c in codes.items() if c == 0),
                       key=lambda k: (k.rsplit("__mutmut_", 1)[0], int(k.rsplit("_", 1)[1])))
    funcs = _functions((mutants / module.path).read_text("utf-8"))
    prefix = module.path[:-3].replace("/", ".") + "."
    lines = []
    for key in survivors:
        fname = key[len(prefix):]
        orig = funcs.get(fname.rsplit("__mutmut_", 1)[0] + "__mutmut_orig", "")
        new = funcs.get(fname, "")
        diff = [d for d in difflib.unified_diff(
            [s.strip() for s in orig.splitlines()[1:]], [s.strip() for s in new.splitlines()[1:]],
            lineterm="", n=0) if d[:1] in "+-" and not d.startswith(("---", "+++"))]
        lines.append(f"{fname}: " + "  ⟶  ".join(d[1:] for d in diff))
    return {"module": module.path, "mutants": len(codes), "judged": judged, "killed": killed,
            "survived": len(survivors), "status": dict(status),
            "score": round(killed / judged, 3) if judged else None, "survivors": lines}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("modules", nargs="*",
                        metavar="MODULE", help=f"one or more of: {', '.join(MODULES)}")
    parser.add_argument("--all", action="store_true", help="every module")
    parser.add_argument("--report", action="store_true", help="only report the last run")
    parser.add_argument("--json", action="store_true", help="the report as JSON")
    parser.add_argument("--max-children", type=int, default=2, help="parallel mutants (2)")
    parser.add_argument("--only", action="append", default=[], metavar="PATTERN",
                        help="check (and report) only the mutants matching this mutmut name "
                             "pattern, e.g. 'marknav.robot.oi.x_command_length__mutmut_*' "
                             "(repeatable; one module)")
    args = parser.parse_args(argv)
    names = list(MODULES) if args.all else args.modules
    if not names:
        parser.error("name a module, or --all")
    unknown = [n for n in names if n not in MODULES]
    if unknown:
        parser.error(f"unknown module {unknown[0]!r} (one of: {', '.join(MODULES)})")
    if args.only and len(names) != 1:
        parser.error("--only needs exactly one module")
    results = []
    for name in names:
        module = MODULES[name]
        if args.only:
            module = replace(module, only=tuple(args.only))
        if not args.report:
            run(name, module, args.max_children)
        result = report(name, module)
        results.append(result)
        if not args.json:
            print(f"{name} ({result['module']}): {result['killed']}/{result['judged']} killed, "
                  f"score {result['score']}, {result['survived']} survived  {result['status']}")
            for line in result["survivors"]:  # type: ignore[attr-defined]
                print(f"  {line}")
    if args.json:
        print(json.dumps(results, indent=2, ensure_ascii=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
