"""A mission whose value has the wrong type where a name belongs (issue 31, B3): exit 2 at
its line for every command that reads missions, never a TypeError.
"""

from __future__ import annotations

from pathlib import Path

from tests.faultkit import (
    run_main,
    slalom_with,
)


def test_a_list_where_a_name_belongs_is_exit_2_at_its_line(tmp_path: Path) -> None:
    """``robot: {model: [create2]}`` without ``wheel_base_mm``: the model was used as a dict key
    before its type was checked (TypeError: unhashable type: 'list')."""
    mission = slalom_with(tmp_path, "  model: create2\n  wheel_base_mm: 235\n",
                           "  model: [create2]\n")
    for command in (["validate"], ["tree"], ["run", "--tree", "none", "--max-time", "1"],
                    ["evaluate", "--runs", "1", "--jobs", "1"]):
        code, err = run_main([command[0], str(mission), *command[1:]], tmp_path)
        assert code == 2, (command, err)
        assert "Traceback" not in err and "TypeError" not in err
        assert f"{mission}:21:" in err and "robot.model" in err, err
