"""Hypothesis fuzzing of every loader: missions, worlds, calibration tables, images, the CLI.

The property everywhere: the input is accepted, or refused with an :class:`InputError` (exit 2
from the CLI) — never another exception, never a traceback. Time and memory are bounded by the
loaders' own limits (file size, YAML depth and expansion, header-claimed image size), which the
generated inputs probe: deep nesting, alias chains, huge claimed sizes, long cells, control
characters. CI runs few examples (``MARKNAV_FUZZ_EXAMPLES``, default 20 per test); set it higher
for a longer hunt, e.g. ``MARKNAV_FUZZ_EXAMPLES=2000 pytest tests/core/test_fuzz_loaders.py``.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import resource
import struct
import tempfile
import zlib
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from marknav.cli.main import main
from marknav.core.errors import InputError, InputErrors
from marknav.missions.schema import load_mission
from marknav.sim.world import load_world
from marknav.vision.calibrate import fit_table
from marknav.vision.imagefile import MAX_IMAGE_PIXELS, read_image

ROOT = Path(__file__).resolve().parents[2]
SLALOM = (ROOT / "missions" / "slalom.yaml").read_text(encoding="utf-8")
WORLD = (ROOT / "missions" / "worlds" / "slalom-world.yaml").read_text(encoding="utf-8")

#: Generous bounds (the worst input takes well under a second): an example that needs 20 s, or a
#: test whose examples grow the process by 256 MiB, means a limit is missing.
FUZZ = settings(max_examples=int(os.environ.get("MARKNAV_FUZZ_EXAMPLES", "20")),
                deadline=timedelta(seconds=20),
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
MAX_GROWTH_KIB = 256 * 1024


@pytest.fixture(autouse=True)
def bounded_memory() -> Iterator[None]:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    yield
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown < MAX_GROWTH_KIB, f"peak memory grew by {grown / 1024:.0f} MiB"


@contextlib.contextmanager
def file_with(data: bytes, suffix: str = "") -> Iterator[str]:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "input" + suffix)
        with open(path, "wb") as fh:
            fh.write(data)
        yield path


# --- YAML: missions and worlds --------------------------------------------------------------

scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(),
                    st.text(max_size=20))
trees = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=5), st.dictionaries(st.text(max_size=10), inner, max_size=5)),
    max_leaves=30)


#: Scalars PyYAML's constructors cannot build: explicit tags on any text, dates and times out of
#: range, integers past Python's 4,300-digit limit.
_TAGS = ["!!int", "!!float", "!!bool", "!!timestamp", "!!null", "!!binary", "!!str", ""]
bad_scalars = st.one_of(
    st.tuples(st.sampled_from(_TAGS), st.text(max_size=12), st.booleans()).map(
        lambda t: f"{t[0]} {json.dumps(t[1]) if t[2] else t[1]}"),
    st.tuples(st.integers(0, 9999), st.integers(0, 99), st.integers(0, 99),
              st.sampled_from(["", " 25:00:00", "T23:59:60", " 12:61:00.5+25:00"])).map(
        lambda t: f"{t[0]:04d}-{t[1]:02d}-{t[2]:02d}{t[3]}"),
    st.integers(4000, 6000).map(lambda n: "9" * n),
)


@st.composite
def yaml_texts(draw: st.DrawFn, base: str) -> str:
    """A real file with lines replaced, text spliced in, deep nesting, alias chains, or a value
    PyYAML cannot construct."""
    kind = draw(st.sampled_from(["splice", "structure", "deep", "aliases", "noise", "scalar"]))
    if kind == "scalar":
        lines = base.splitlines()
        keyed = [i for i, ln in enumerate(lines) if re.match(r"^\s*[a-z_]+: \S", ln)]
        i = draw(st.sampled_from(keyed))
        lines[i] = lines[i].split(":", 1)[0] + ": " + draw(bad_scalars)
        return "\n".join(lines)
    if kind == "structure":
        return yaml.safe_dump(draw(trees), allow_unicode=True)
    if kind == "deep":
        depth = draw(st.integers(1, 600))
        opener, closer = draw(st.sampled_from([("[", "]"), ("{a: ", "}")]))
        return "name: " + opener * depth + "1" + closer * depth + "\n"
    if kind == "aliases":
        levels, width = draw(st.integers(1, 12)), draw(st.integers(1, 12))
        lines = ["a0: &a0 [" + ", ".join(["x"] * width) + "]"]
        lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]"
                  for i in range(1, levels)]
        if draw(st.booleans()):
            lines.append("loop: &l [*l]")
        return "\n".join(lines) + "\n"
    if kind == "noise":
        return draw(st.text(max_size=400))
    lines = base.splitlines()
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        lines[i] = draw(st.sampled_from([
            "", lines[i][: draw(st.integers(0, len(lines[i])))],
            lines[i] + draw(st.text(max_size=30)), draw(st.text(max_size=60)),
        ]))
    return "\n".join(lines)


def loads_or_input_error(loader: object, data: bytes) -> None:
    with file_with(data, ".yaml") as path:
        try:
            loader(path)  # type: ignore[operator]
        except InputError as exc:
            # every problem found is named at the file that was loaded (FILE[:LINE[:COL]]: ...)
            # with a message, whatever the input
            problems = exc.errors if isinstance(exc, InputErrors) else [exc]
            for problem in problems:
                assert problem.file == path, str(problem)
                assert str(problem).startswith(f"{path}:"), str(problem)
                assert problem.message.strip(), str(problem)


#: Inputs every run tries first, whatever Hypothesis draws: broken YAML syntax, a document that
#: is not a mapping, bytes that are not UTF-8.
BROKEN = [
    example(text="name: [slalom\nroute: [red]\n", raw=False, junk=b""),
    example(text="- just\n- a list\n", raw=False, junk=b""),
    example(text="", raw=True, junk=b"\xff\xfe\x00name: x\n"),
]


def with_broken(test: Any) -> Any:
    for ex in BROKEN:
        test = ex(test)
    return test


@FUZZ
@with_broken
@given(text=yaml_texts(SLALOM), raw=st.booleans(), junk=st.binary(max_size=200))
def test_fuzz_mission_loader(text: str, raw: bool, junk: bytes) -> None:
    loads_or_input_error(load_mission, junk if raw else text.encode("utf-8", "surrogatepass"))


@FUZZ
@with_broken
@given(text=yaml_texts(WORLD), raw=st.booleans(), junk=st.binary(max_size=200))
def test_fuzz_world_loader(text: str, raw: bool, junk: bytes) -> None:
    loads_or_input_error(load_world, junk if raw else text.encode("utf-8", "surrogatepass"))


# --- calibration tables ---------------------------------------------------------------------

cells = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**30, 10**30).map(str),
    st.floats(1e-3, 1e4).map(lambda v: f"{v:.17g}"),
    st.text(max_size=30),
    st.integers(0, 200_000).map(lambda n: "9" * n),
)


@FUZZ
@given(rows=st.lists(st.lists(cells, min_size=0, max_size=3), max_size=25),
       bom=st.booleans(), crlf=st.booleans(), header=st.booleans())
def test_fuzz_table_loader(rows: list[list[str]], bom: bool, crlf: bool, header: bool) -> None:
    nl = "\r\n" if crlf else "\n"
    text = ("\ufeff" if bom else "") + ("radius_px,distance_mm" + nl if header else "")
    text += nl.join(",".join(r) for r in rows)
    with file_with(text.encode("utf-8", "surrogatepass"), ".csv") as path:
        try:
            fit = fit_table(path)
        except InputError as exc:
            assert path in str(exc)
        else:
            assert math.isfinite(fit.a) and fit.a > 0 and fit.b < 0


# --- images -----------------------------------------------------------------------------------

def _encoded(ext: str) -> bytes:
    image = np.zeros((24, 32, 3), np.uint8)
    cv2.circle(image, (16, 12), 8, (0, 0, 255), -1)
    ok, buf = cv2.imencode(ext, image)
    assert ok
    return buf.tobytes()


ENCODED = {ext: _encoded(ext) for ext in (".png", ".jpg", ".bmp", ".tif", ".webp", ".ppm")}


def _png_claiming(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2,
                                                              0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))


@st.composite
def image_bytes(draw: st.DrawFn) -> bytes:
    kind = draw(st.sampled_from(["mutate", "claim", "noise"]))
    if kind == "claim":
        return _png_claiming(draw(st.integers(0, 2**32 - 1)), draw(st.integers(0, 2**32 - 1)))
    if kind == "noise":
        return draw(st.binary(max_size=300))
    data = bytearray(ENCODED[draw(st.sampled_from(sorted(ENCODED)))])
    for _ in range(draw(st.integers(1, 8))):
        i = draw(st.integers(0, min(len(data) - 1, 64)))  # mostly the header
        data[i] = draw(st.integers(0, 255))
    return bytes(data[: draw(st.integers(0, len(data)))])


@FUZZ
@given(data=image_bytes())
def test_fuzz_image_loader(data: bytes) -> None:
    with file_with(data, ".png") as path:
        try:
            image = read_image(path)
        except InputError as exc:
            assert path in str(exc)
        else:
            assert image.ndim == 3 and image.shape[0] * image.shape[1] <= MAX_IMAGE_PIXELS


# --- the command line -------------------------------------------------------------------------

OPTIONS = ["--max-time", "--seed", "--world", "--robot", "--camera", "--report", "--events",
           "--plot", "--tree", "--json", "--dot", "--unicode", "--sim", "--annotate", "-v"]
values = st.one_of(st.sampled_from(["nan", "-1", "0", "1e400", "inf", "", "sim", "runs",
                                    "r.json", "missing/r.json", "/dev/full", "generate"]),
                   st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=12))


@pytest.fixture(scope="module")
def workdir() -> Iterator[Path]:
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "bad.yaml").write_text("name: [\n", encoding="utf-8")
        Path(tmp, "t.csv").write_text("radius_px,distance_mm\n1,2\n", encoding="utf-8")
        Path(tmp, "i.png").write_bytes(_png_claiming(10**5, 10**5))
        yield Path(tmp)


@FUZZ
@given(command=st.sampled_from(["run", "validate", "tree", "calibrate", "detect", "schema"]),
       files=st.lists(st.sampled_from(["bad.yaml", "t.csv", "i.png", "none.yaml", "/dev/zero",
                                       "."]), max_size=2),
       options=st.lists(st.tuples(st.sampled_from(OPTIONS), values), max_size=4))
def test_fuzz_cli_arguments(workdir: Path, command: str, files: list[str],
                            options: list[tuple[str, str]]) -> None:
    argv = [command, *files]
    for option, value in options:
        argv += [option] if option in ("--json", "--unicode", "--sim", "-v") else [option, value]
    err = io.StringIO()
    old = os.getcwd()
    os.chdir(workdir)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse: usage errors and --help
                code = int(exc.code or 0)
    finally:
        os.chdir(old)
    assert code in (0, 1, 2), (argv, err.getvalue())
    assert "Traceback" not in err.getvalue()
    if command == "run":  # every run here has bad input: a missing or invalid mission
        assert code == 2, (argv, err.getvalue())


# --- whole missions and worlds through the command line (issue 31) ---------------------------

MISSIONS = sorted((ROOT / "missions").glob("*.yaml"))
#: A mutation makes a file wrong in one place: a value of the wrong type where any other is
#: expected (a list where a name is used as a key: the TypeError of issue 31 B3), or a key no
#: schema has. Every one must be refused, exit 2, at FILE:LINE, never with a traceback.
MUTATION_EXAMPLES = int(os.environ.get("MARKNAV_FUZZ_MUTATIONS", "150"))
MUTATE = settings(max_examples=MUTATION_EXAMPLES, deadline=None,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                         HealthCheck.function_scoped_fixture])


def _with_absolute_world(path: Path) -> tuple[Any, Path | None]:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    world = None
    if isinstance(data.get("sim"), dict) and data["sim"].get("world"):
        world = (path.parent / data["sim"]["world"]).resolve()
        data["sim"]["world"] = str(world)
    return data, world


def _nodes(tree: Any, at: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """The path of every mapping value and list item."""
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield (*at, k)
            yield from _nodes(v, (*at, k))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            yield (*at, i)
            yield from _nodes(v, (*at, i))


def _wrong_types(value: Any) -> list[Any]:
    """Values of another type than ``value``, none of which a schema would coerce into it."""
    if isinstance(value, bool):
        return [[value], {"x": value}, "maybe"]
    if isinstance(value, (int, float)):
        return [[value], {"value": value}, "many", None]
    if isinstance(value, str):
        return [[value], {value: value}, [[value]]]
    if isinstance(value, list):
        return [{"x": value}, 7, True]
    if isinstance(value, dict):
        return [[value], [list(value)], 7]
    return [[value], {"x": 1}]


@st.composite
def mutated(draw: st.DrawFn) -> tuple[str, Any, Path | None]:
    """One mission or world file from missions/, wrong in one place: ('mission'|'world', the
    data, the mission's world)."""
    mission = draw(st.sampled_from(MISSIONS))
    data, world = _with_absolute_world(mission)
    kind = draw(st.sampled_from(["mission", "world"] if world is not None else ["mission"]))
    if kind == "world":
        assert world is not None
        data = yaml.safe_load(world.read_text(encoding="utf-8"))
    at = draw(st.sampled_from(list(_nodes(data))))
    parent = data
    for part in at[:-1]:
        parent = parent[part]
    if draw(st.booleans()) and isinstance(parent, dict):
        parent[draw(st.sampled_from(["colour_", "sides", "x_mn", "Model", "unknown"]))] = 1
    else:
        parent[at[-1]] = draw(st.sampled_from(_wrong_types(parent[at[-1]])))
    return kind, data, world


@MUTATE
@given(case=mutated())
def test_fuzz_mutated_missions_and_worlds_exit_2_at_file_and_line(
        case: tuple[str, Any, Path | None], tmp_path_factory: pytest.TempPathFactory) -> None:
    kind, data, world = case
    folder = tmp_path_factory.mktemp("mutated")
    bad = folder / f"{kind}.yaml"
    bad.write_text(yaml.safe_dump(data, allow_unicode=True), encoding="utf-8")
    if kind == "mission":
        argv = ["validate", str(bad)]
    else:  # the world through the mission it belongs to, as 'run --world' would load it
        mission = next(m for m in MISSIONS if _with_absolute_world(m)[1] == world)
        argv = ["validate", str(mission), "--world", str(bad)]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    text = err.getvalue()
    assert code == 2, (argv, bad.read_text(), text)
    assert "Traceback" not in text, text
    assert re.search(re.escape(str(bad)) + r":\d+:", text), (bad.read_text(), text)
