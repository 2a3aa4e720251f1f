"""``marknav random-mission``: write the mission and world that ``marknav evaluate --missions
random`` draws for a seed, so a failing run can be replayed, plotted and inspected."""

from __future__ import annotations

import argparse

from marknav.core.errors import InputError


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "random-mission",
        help="write the generated mission + world of an evaluation seed",
        description=(
            "Write OUT/mission.yaml and OUT/world.yaml: the mission and world that "
            "'marknav evaluate --missions random' runs for seed SEED. 'marknav run "
            "OUT/mission.yaml --seed SEED' then replays that run exactly."
        ),
    )
    p.add_argument("--seed", type=int, required=True, metavar="SEED", help="the run's seed")
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write to")
    p.add_argument("--engine", choices=("builtin", "mujoco"), default="builtin",
                   help="the engine the evaluation ran (default builtin); mujoco's missions "
                   "get MuJoCo's room (lamps, textures, distractors) and marks turned up to 60°")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from marknav.runs.evaluation.random_mission import write_random_mission

    if args.seed < 0:
        raise InputError(f"must be ≥ 0, got {args.seed}", field="--seed")
    try:
        mission_path, world_path = write_random_mission(args.seed, args.out, args.engine)
    except OSError as exc:
        raise InputError(f"cannot write there: {exc.strerror or exc}", file=args.out) from None
    print(f"mission: {mission_path}  world: {world_path}")
    flag = f" --engine {args.engine}" if args.engine != "builtin" else ""
    print(f"replay: marknav run {mission_path} --seed {args.seed}{flag}")
    return 0
