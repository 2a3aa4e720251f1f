"""The example missions and their simulator worlds, shipped inside the package.

An installed marknav (a wheel, no checkout) runs its demo by name: ``marknav run slalom`` finds
``slalom.yaml`` here when no file ``slalom`` exists, and ``marknav examples DIR`` copies the
missions and their ``worlds/`` out to edit. A mission names its world relative to itself
(``sim: {world: worlds/slalom-world.yaml}``), so the copies run wherever they are put.

The repository's ``missions/`` folder holds the same files (the README's commands use it from a
checkout); a test keeps the two identical.
"""

from __future__ import annotations

import contextlib
import difflib
import shutil
import stat
from pathlib import Path

from marknav.core.errors import InputError
from marknav.core.inputfile import stat_path

__all__ = ["EXAMPLES_DIR", "copy_examples", "example_files", "example_names", "mission_path"]

#: The folder of the example missions (``worlds/`` below it).
EXAMPLES_DIR = Path(__file__).resolve().parent


def example_names() -> list[str]:
    """The examples' names (their file names without ``.yaml``), sorted."""
    return sorted(p.stem for p in EXAMPLES_DIR.glob("*.yaml"))


def example_files() -> list[Path]:
    """Every example file, relative to :data:`EXAMPLES_DIR`: the missions, then the worlds."""
    return [p.relative_to(EXAMPLES_DIR) for p in
            [*sorted(EXAMPLES_DIR.glob("*.yaml")), *sorted(EXAMPLES_DIR.glob("worlds/*.yaml"))]]


def _is_bare_name(text: str) -> bool:
    return bool(text) and "/" not in text and "\\" not in text and not text.endswith(
        (".yaml", ".yml"))


def mission_path(text: str) -> str:
    """The mission file ``text`` names: itself when it is a file (or looks like a path), else
    the built-in example of that name. A bare name that is neither raises :class:`InputError`
    listing the examples."""
    if stat_path(text) is not None:
        return text
    if not _is_bare_name(text):
        _refuse_example_path(text)
        return text  # the loader reports a missing path with its own message
    names = example_names()
    if text in names:
        return str(EXAMPLES_DIR / f"{text}.yaml")
    close = difflib.get_close_matches(text, names, n=1)
    hint = f"did you mean {close[0]}? " if close else ""
    raise InputError(f"no such file, and no built-in example of that name; {hint}examples: "
                     f"{', '.join(names)} ('marknav examples DIR' copies them out to edit)",
                     file=text)


def _refuse_example_path(text: str) -> None:
    """A missing path whose file name is a built-in example's (``missions/slalom.yaml`` from
    the README, typed outside the repository): InputError saying how to use the built-in one."""
    name = Path(text.replace("\\", "/")).name
    stem = name.rsplit(".", 1)[0] if name.endswith((".yaml", ".yml")) else None
    if stem is None or stem not in example_names():
        return
    raise InputError(f"no such file; {stem} is a built-in example: give its name instead "
                     f"('marknav run {stem}'), or copy the examples out to edit "
                     f"('marknav examples DIR', then 'marknav run DIR/{name}')", file=text)


def copy_examples(dest: Path) -> list[Path]:
    """Copy the examples into ``dest`` (created if needed); the paths written. All or nothing:
    if any of the files is already there, :class:`InputError` names them and nothing is
    copied; if a write fails (a full disk, a name too long), what was copied and the folders
    made for it are removed again before the :class:`InputError`."""
    files = example_files()
    st = stat_path(dest, field="DIR")
    if st is not None and not stat.S_ISDIR(st.st_mode):
        raise InputError("exists and is not a folder", file=str(dest))
    there = [f for f in files if stat_path(dest / f, field="DIR") is not None]
    if there:
        listed = ", ".join(str(f) for f in there[:4]) + (" ..." if len(there) > 4 else "")
        raise InputError(f"would overwrite {len(there)} file{'s' if len(there) != 1 else ''} "
                         f"({listed}): choose another folder or move them first",
                         file=str(dest))
    written: list[Path] = []
    made: list[Path] = []  # folders this copy created, outermost first
    try:
        for f in files:
            target = dest / f
            missing = [d for d in (target.parent, *target.parent.parents)
                       if stat_path(d, field="DIR") is None]
            for folder in reversed(missing):
                folder.mkdir()
                made.append(folder)
            written.append(target)  # before the copy: a half-written file is removed too
            shutil.copyfile(EXAMPLES_DIR / f, target)
    except (OSError, InputError) as exc:
        _undo(written, made)
        why = exc.strerror or str(exc) if isinstance(exc, OSError) else exc.message
        raise InputError(f"cannot write: {why}; nothing was copied", file=str(dest)) from None
    return written


def _undo(written: list[Path], made: list[Path]) -> None:
    """Remove a half-done copy: the files that got written (the last perhaps in part), then the
    folders made for them, innermost first."""
    for path in written:
        with contextlib.suppress(OSError):
            path.unlink(missing_ok=True)
    for folder in reversed(made):
        with contextlib.suppress(OSError):
            folder.rmdir()
