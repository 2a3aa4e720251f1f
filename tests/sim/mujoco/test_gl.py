"""A headless OpenGL library that the linker cache names but that does not load, or lacks what
MuJoCo calls, is refused like a missing one: exit 2 naming the system package, no run folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.core.errors import InputError
from marknav.sim.mujoco import gl


class _NoSymbols:
    """A loaded library that exports nothing."""

    def __getattr__(self, name: str) -> object:
        raise AttributeError(name)


def _unloadable(_soname: str, *_a: object, **_k: object) -> object:
    raise OSError("cannot open shared object file: undefined symbol")


def _without_symbols(_soname: str, *_a: object, **_k: object) -> object:
    return _NoSymbols()


@pytest.fixture(params=[_unloadable, _without_symbols], ids=["unloadable", "no-symbol"])
def broken_osmesa(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """``MUJOCO_GL=osmesa`` with a library the linker cache lists but that cannot serve MuJoCo."""
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(gl.ctypes.util, "find_library", lambda name: "libOSMesa.so.8")
    monkeypatch.setattr(gl.ctypes, "CDLL", request.param)


@pytest.mark.usefixtures("broken_osmesa")
def test_a_listed_but_broken_library_is_missing_naming_the_package() -> None:
    message = gl.missing_library()
    assert message is not None and "apt-get install -y libosmesa6" in message
    with pytest.raises(InputError, match="libosmesa6"):
        gl.import_mujoco()


def test_a_library_that_loads_with_its_symbol_is_present(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[str] = []

    class _Library:
        def __getattr__(self, name: str) -> object:
            seen.append(name)
            return object()

    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(gl.ctypes, "CDLL", lambda soname, *a, **k: _Library())
    assert gl.missing_library() is None
    assert seen == ["OSMesaCreateContextExt"]


@pytest.mark.parametrize("error", [AttributeError("OSMesaCreateContextExt"), OSError("no lib")])
def test_mujocos_own_gl_setup_failing_is_an_input_error(
        error: Exception, monkeypatch: pytest.MonkeyPatch) -> None:
    def fail(name: str) -> object:
        raise error

    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(gl, "_library_present", lambda name: True)
    monkeypatch.setattr(gl.importlib, "import_module", fail)
    with pytest.raises(InputError, match="libosmesa6") as caught:
        gl.import_mujoco()
    assert caught.value.field == "--engine"


@pytest.mark.usefixtures("broken_osmesa")
@pytest.mark.parametrize("argv", [
    ["run", "slalom", "--engine", "mujoco"],
    ["evaluate", "slalom", "--engine", "mujoco", "--runs", "1"],
    ["bench", "mujoco"],
])
def test_the_commands_exit_2_before_any_run_folder(
    argv: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("marknav.cli.requirements._module_present", lambda name: True)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "libosmesa6" in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []
