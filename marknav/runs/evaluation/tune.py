"""Parameter search for a mission (``marknav tune``, issue 16), with Optuna.

Each trial sets the ``--param`` keys of the mission (dotted paths, e.g.
``navigation.clearance_mm``) to values drawn by Optuna's TPE sampler, writes that mission to
the study's folder and evaluates it (:func:`marknav.runs.evaluation.evaluate.evaluate`) on the SAME
seeds — the same randomised worlds — as every other trial, locally or on a Dask cluster.

Objective (minimised), lexicographic by construction: success rate first, then the median
simulated mission time::

    value = (1 − success_rate) · W + median_sim_time_s,   W = (runs + 1) · max_time_s

One more failed run costs W / runs > max_time_s, more than any median time can differ, so a
trial with more successes always wins; among equal success rates the faster one wins.

The study lives in its own storage (default ``sqlite:///runs/tune-NAME/study.sqlite3``) with
the parameter space, seeds and time limit recorded; running the same command again resumes it
until ``--trials`` trials are complete (a trial cut short by Ctrl-C is recorded as failed and
does not count; a combination the mission schema refuses, e.g. a bypass distance under the
clearance, is pruned and does not count either). A study made with other parameters, seeds or
runs is refused.
"""

from __future__ import annotations

import copy
import json
import logging
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from marknav.core.errors import InputError
from marknav.core.figures import save_figure

__all__ = ["Param", "TuneResult", "best_yaml", "parse_param", "plot_trials", "tune"]

log = logging.getLogger(__name__)

#: Give up after this many times --trials draws (invalid combinations are pruned, not counted).
MAX_ATTEMPTS_FACTOR = 5

_PARAM = re.compile(r"^(?P<key>[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)+)=(?P<lo>[^:]+):(?P<hi>[^:]+)"
                    r"(:(?P<step>[^:]+))?$")


@dataclass(frozen=True)
class Param:
    """One searched parameter: a dotted mission key and its range (``step`` optional)."""

    key: str
    low: float
    high: float
    step: float | None = None

    @property
    def integer(self) -> bool:
        return self.step is not None and all(float(v).is_integer()
                                             for v in (self.low, self.high, self.step))

    def spec(self) -> str:
        step = f":{self.step:g}" if self.step is not None else ""
        return f"{self.key}={self.low:g}:{self.high:g}{step}"

    def suggest(self, trial: Any) -> float | int:
        if self.integer:
            return int(trial.suggest_int(self.key, int(self.low), int(self.high),
                                         step=int(self.step or 1)))
        return float(trial.suggest_float(self.key, self.low, self.high, step=self.step))


def parse_param(text: str) -> Param:
    """``navigation.clearance_mm=250:450`` (or ``…=250:450:10``) → :class:`Param`."""
    m = _PARAM.match(text.strip())
    if m is None:
        raise InputError(f"expected KEY=LOW:HIGH[:STEP] with a dotted mission key, e.g. "
                         f"navigation.clearance_mm=250:450; got {text!r}", field="--param")
    try:
        low, high = float(m["lo"]), float(m["hi"])
        step = float(m["step"]) if m["step"] is not None else None
    except ValueError:
        raise InputError(f"{text!r}: LOW, HIGH and STEP must be numbers",
                         field="--param") from None
    if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
        raise InputError(f"{text!r}: need finite LOW < HIGH", field="--param")
    if step is not None and not 0 < step <= high - low:
        raise InputError(f"{text!r}: STEP must be in (0, HIGH − LOW]", field="--param")
    return Param(m["key"], low, high, step)


def _set_key(doc: dict[str, Any], key: str, value: Any) -> None:
    parts = key.split(".")
    node: Any = doc
    for part in parts[:-1]:
        nxt = node.get(part) if isinstance(node, dict) else None
        if nxt is None:
            nxt = node[part] = {}
        if not isinstance(nxt, dict):
            raise InputError(f"{'.'.join(parts[:parts.index(part) + 1])} is not a mapping in "
                             "the mission", field=f"--param {key}")
        node = nxt
    node[parts[-1]] = value


def _trial_mission(source: Path, doc: dict[str, Any], values: dict[str, Any], out: Path
                   ) -> Path:
    """Write the mission ``doc`` with ``values`` set to ``out``; relative file references
    (``sim.world``) are made absolute so the copy means the same as the original."""
    trial = copy.deepcopy(doc)
    sim = trial.get("sim")
    if isinstance(sim, dict) and isinstance(sim.get("world"), str):
        world = Path(sim["world"])
        if not world.is_absolute():
            sim["world"] = str((source.parent / world).resolve())
    for key, value in values.items():
        _set_key(trial, key, value)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(f"# {source} with {json.dumps(values)} (marknav tune)\n"
                   + yaml.safe_dump(trial, sort_keys=False), encoding="utf-8")
    return out


def _check_params(source: Path, doc: dict[str, Any], params: Sequence[Param], folder: Path
                  ) -> None:
    """Every key must be a field the mission accepts at both ends of its range."""
    from marknav.missions.schema import load_mission

    if len({p.key for p in params}) != len(params):
        raise InputError("a key is given twice", field="--param")
    for end in ("low", "high"):
        values = {p.key: (int(getattr(p, end)) if p.integer else getattr(p, end))
                  for p in params}
        path = _trial_mission(source, doc, values, folder / f"check-{end}.yaml")
        try:
            mission = load_mission(path)
        except InputError as exc:
            what = f"{exc.field}: {exc.message}" if exc.field else exc.message
            raise InputError(f"{source} is invalid with {values}: {what}",
                             field="--param") from None
        finally:
            path.unlink(missing_ok=True)
        dumped = mission.model_dump()
        for key, value in values.items():
            node: Any = dumped
            for part in key.split("."):
                node = node.get(part) if isinstance(node, dict) else None
            if node is None or float(node) != float(value):
                raise InputError(f"{key} is not a mission field", field="--param")


@dataclass
class TrialSummary:
    number: int
    params: dict[str, Any]
    value: float
    success_rate: float
    successes: int
    runs: int
    median_time_s: float


@dataclass
class TuneResult:
    mission: str
    storage: str
    study_name: str
    trials: list[TrialSummary]
    best: TrialSummary
    new_trials: int
    plot: Path | None = None


def _objective_value(success_rate: float, median_s: float, runs: int, max_time_s: float
                     ) -> float:
    return (1.0 - success_rate) * (runs + 1) * max_time_s + median_s


def tune(
    mission_path: str | Path,
    params: Sequence[Param],
    *,
    trials: int,
    runs: int = 5,
    seed: int = 0,
    jobs: int = 1,
    dask: str | None = None,
    max_time_s: float | None = None,
    storage: str | None = None,
    study_name: str | None = None,
    sampler_seed: int = 0,
    folder: Path | None = None,
    on_trial: Callable[[TrialSummary, TrialSummary, int], None] | None = None,
    on_start: Callable[[int], object] | None = None,
) -> TuneResult:
    """Run (or resume) the study until ``trials`` trials are complete; see the module docstring.
    ``on_start(complete)`` is called once the study is open (``complete``: trials it already
    has), ``on_trial(trial, best, complete)`` after each trial."""
    try:
        import optuna
    except ImportError:
        raise InputError("needs optuna: pip install 'marknav[cluster]'") from None
    from marknav.core.yamlio import load_yaml_file
    from marknav.missions.schema import load_mission
    from marknav.runs.evaluation.evaluate import evaluate
    from marknav.runs.loop.run import default_max_time_s

    if not params:
        raise InputError("give at least one --param KEY=LOW:HIGH", field="--param")
    if trials < 1:
        raise InputError(f"must be at least 1, got {trials}", field="--trials")
    if runs < 1:
        raise InputError(f"must be at least 1, got {runs}", field="--runs")
    source = Path(mission_path)
    mission = load_mission(source)  # bad input fails here
    doc = load_yaml_file(source).data
    if not isinstance(doc, dict):
        raise InputError("a mission is a mapping", file=str(source))
    limit = max_time_s if max_time_s is not None else default_max_time_s(mission)
    folder = folder if folder is not None else Path("runs") / f"tune-{_safe(mission.name)}"
    folder.mkdir(parents=True, exist_ok=True)
    _check_params(source, doc, params, folder)
    storage = storage or f"sqlite:///{folder / 'study.sqlite3'}"
    study_name = study_name or _safe(mission.name)
    space = {"params": [p.spec() for p in params], "runs": runs, "seed": seed,
             "max_time_s": limit, "mission": str(source.resolve())}

    # Optuna's own per-trial lines (and its warning for a trial cut short by Ctrl-C) only
    # with -v: the command prints its own line per trial.
    optuna.logging.set_verbosity(optuna.logging.INFO if log.isEnabledFor(logging.INFO)
                                 else optuna.logging.ERROR)
    try:
        study = optuna.create_study(
            study_name=study_name, storage=storage, direction="minimize", load_if_exists=True)
    except (ValueError, ImportError, optuna.exceptions.OptunaError) as exc:
        raise InputError(f"cannot open the study storage {storage}: {exc}",
                         field="--storage") from None
    # The sampler's seed moves on with the study: a resumed study must not draw the same
    # start-up points again (a new sampler with the same seed repeats its random draws).
    study.sampler = optuna.samplers.TPESampler(seed=sampler_seed + len(study.trials))
    recorded = study.user_attrs.get("space")
    if recorded is None:
        study.set_user_attr("space", space)
    elif recorded != space:
        raise InputError(f"study {study_name!r} in {storage} was made with {recorded}, not "
                         f"{space}: use the same parameters, runs, seed and time limit to "
                         f"resume, or another --storage/--study", field="--storage")

    def complete() -> list[Any]:
        return study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))

    def objective(trial: Any) -> float:
        values = {p.key: p.suggest(trial) for p in params}
        path = _trial_mission(source, doc, values, folder / f"trial-{trial.number:04d}.yaml")
        try:
            load_mission(path)
        except InputError as exc:  # a combination the schema refuses: not a result
            log.warning("trial %d: %s is not a valid mission (%s): pruned", trial.number,
                        values, exc.message)
            trial.set_user_attr("invalid", exc.message)
            raise optuna.TrialPruned(exc.message) from None
        ev = evaluate(path, runs=runs, seed=seed, jobs=jobs, dask=dask, max_time_s=limit,
                      min_success=0.0)
        trial.set_user_attr("success_rate", ev.success_rate)
        trial.set_user_attr("successes", ev.successes)
        trial.set_user_attr("runs", ev.runs)
        trial.set_user_attr("median_time_s", ev.sim_time_median_s)
        return _objective_value(ev.success_rate, ev.sim_time_median_s, runs, limit)

    def callback(study: Any, frozen: Any) -> None:
        if on_trial is not None and frozen.state == optuna.trial.TrialState.COMPLETE:
            on_trial(_summary(frozen), _summary(study.best_trial), len(complete()))

    remaining = trials - len(complete())
    if on_start is not None:
        on_start(len(complete()))
    attempts = 0
    while len(complete()) < trials:
        if attempts >= MAX_ATTEMPTS_FACTOR * trials:
            raise InputError(f"{attempts} trials drew no valid mission: narrow the ranges",
                             field="--param")
        wanted = trials - len(complete())
        attempts += wanted
        study.optimize(objective, n_trials=wanted, callbacks=[callback], catch=())
    done = [_summary(t) for t in complete()]
    return TuneResult(mission=mission.name, storage=storage, study_name=study_name,
                      trials=done, best=_summary(study.best_trial),
                      new_trials=max(remaining, 0))


def _summary(t: Any) -> TrialSummary:
    return TrialSummary(number=t.number, params=dict(t.params), value=float(t.value),
                        success_rate=float(t.user_attrs["success_rate"]),
                        successes=int(t.user_attrs["successes"]), runs=int(t.user_attrs["runs"]),
                        median_time_s=float(t.user_attrs["median_time_s"]))


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "mission"


def _nested(values: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in values.items():
        _set_key(out, key, round(value, 1) if isinstance(value, float) else value)
    return out


def best_yaml(result: TuneResult) -> str:
    """The best trial's parameters as a YAML block to paste into the mission."""
    b = result.best
    head = (f"# marknav tune {result.mission}: best of {len(result.trials)} trials (trial "
            f"{b.number}): success {b.successes}/{b.runs} = {b.success_rate:.0%}, median "
            f"{b.median_time_s:.1f} s")
    return head + "\n" + yaml.safe_dump(_nested(b.params), sort_keys=False).rstrip()


#: Unit of a mission key, by the suffix the mission schema gives it.
_KEY_UNITS = (("_mm_s", "mm/s"), ("_deg_s", "deg/s"), ("_mm", "mm"), ("_deg", "deg"),
              ("_hz", "Hz"), ("_s", "s"), ("_px", "px"))


def key_label(key: str) -> str:
    """An axis label for a mission key: the key and, where its suffix says it, its unit
    (``navigation.clearance_mm`` → ``navigation.clearance_mm [mm]``)."""
    for suffix, unit in _KEY_UNITS:
        if key.endswith(suffix):
            return f"{key} [{unit}]"
    return f"{key} [as in the mission]"


def plot_trials(result: TuneResult, params: Sequence[Param], out: Path) -> None:
    """Left: each trial's success rate and median time, and the best value so far; right: the
    first two parameters of every trial, coloured by success rate (the best one starred)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import MaxNLocator
    except ImportError:
        raise InputError("the plot needs matplotlib: pip install 'marknav[plot]'",
                         field="--plot") from None
    ts = sorted(result.trials, key=lambda t: t.number)
    n = [t.number for t in ts]
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11.0, 4.4), dpi=100)
    ax.plot(n, [100 * t.success_rate for t in ts], "o", color="tab:green", label="success %")
    ax.set_xlabel("trial [number]")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # trials are whole numbers
    ax.set_ylabel("success rate [%]", color="tab:green")
    ax.set_ylim(-5, 105)
    axt = ax.twinx()
    axt.plot(n, [t.median_time_s for t in ts], "s", color="tab:blue", ms=4,
             label="median time")
    best_so_far, best = [], math.inf
    for t in ts:
        best = min(best, t.value)
        best_so_far.append(next(x.median_time_s for x in ts if x.value == best))
    axt.step(n, best_so_far, where="post", color="tab:blue", lw=1,
             label="median time of the best so far")
    axt.set_ylabel("median mission time [s]", color="tab:blue")
    ax.grid(True, alpha=0.3)
    handles = ax.get_legend_handles_labels()[0] + axt.get_legend_handles_labels()[0]
    ax.legend(handles=handles, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16),
              ncol=3, frameon=False)
    keys = [p.key for p in params]
    xs = [t.params.get(keys[0]) for t in ts]
    ys = [t.params.get(keys[1]) for t in ts] if len(keys) > 1 else [t.median_time_s for t in ts]
    sc = ax2.scatter(xs, ys, c=[100 * t.success_rate for t in ts], cmap="RdYlGn", vmin=0,
                     vmax=100, edgecolors="k")
    ax2.scatter([result.best.params.get(keys[0])],
                [result.best.params.get(keys[1]) if len(keys) > 1
                 else result.best.median_time_s], marker="*", s=300, facecolors="none",
                edgecolors="k", label=f"best (trial {result.best.number})")
    ax2.set_xlabel(key_label(keys[0]))
    ax2.set_ylabel(key_label(keys[1]) if len(keys) > 1 else "median mission time [s]")
    ax2.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)
    fig.colorbar(sc, ax=ax2, label="success rate [%]")
    fig.suptitle(f"marknav tune {result.mission}: {len(ts)} trials", fontsize=10)
    save_figure(fig, out)
