"""``marknav serve-tree``: the page's data from a run log and from a live Groot2 server, and the
page itself in a real headless browser (Debian's chromium and chromium-driver, selenium): it
loads with nothing from the network, draws the tree, and moving the timeline changes the
statuses."""

from __future__ import annotations

import json
import re
import shutil
import socket
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import py_trees
import pytest

from marknav.runs.records.tree_state import TreeState
from marknav.runs.views.tree_page import LiveSource, LogSource, TreePageServer, page_html

TREE = {"names": ["Mission", "Approach", "Bypass"], "kinds": ["sequence", "leaf", "leaf"],
        "parents": [-1, 0, 0], "memory": [True, False, False]}


def free_port_pair() -> int:
    """A TCP port P with P + 1 free too (a Groot2 server's two)."""
    for _ in range(50):
        with socket.socket() as a:
            a.bind(("127.0.0.1", 0))
            port = int(a.getsockname()[1])
            with socket.socket() as b:
                try:
                    b.bind(("127.0.0.1", port + 1))
                except OSError:
                    continue
        return port
    raise RuntimeError("no two free ports in a row")


def _records() -> list[dict[str, Any]]:
    return [
        {"t": 0.0, "kind": "tree", "tree": TREE, "mission": {"name": "demo"}},
        {"t": 0.0, "kind": "tick", "n": 0, "panel": {"target": "red"},
         "nodes": {"0": ["RUNNING", ""], "1": ["RUNNING", "closing in"]}},
        {"t": 0.05, "kind": "tick", "n": 1, "panel": {"target": "red"},
         "nodes": {"1": ["SUCCESS", "in range"], "2": ["RUNNING", "curve 1"]},
         "bb": {"/marknav/target": {"colour": "red"}}},
        {"t": 0.1, "kind": "tick", "n": 2, "panel": {"target": "none"},
         "nodes": {"0": ["SUCCESS", ""], "2": ["SUCCESS", "passed"]}},
    ]


def _get(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=5) as reply:
        return json.loads(reply.read())


def test_the_api_serves_tree_and_ticks_of_a_run_log() -> None:
    server = TreePageServer(LogSource(_records())).start()
    try:
        tree = _get(server.url + "api/tree")
        assert tree["names"] == TREE["names"] and tree["title"] == "demo"
        assert tree["live"] is False
        ticks = _get(server.url + "api/ticks?since=1")
        assert [t["n"] for t in ticks] == [1, 2]
        assert ticks[0]["nodes"]["2"] == ["RUNNING", "curve 1"]
        for bad, code in (("api/ticks?since=x", 400), ("nothing", 404)):
            with pytest.raises(urllib.error.HTTPError) as err:
                urllib.request.urlopen(server.url + bad, timeout=5)
            assert err.value.code == code
    finally:
        server.close()


def test_the_page_loads_nothing_from_the_network() -> None:
    html = page_html().decode()
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", html)
    assert "@import" not in html and "<link" not in html


def test_a_live_source_follows_a_groot2_server() -> None:
    pytest.importorskip("zmq")
    from marknav.runs.views.groot2 import Groot2Server

    root = py_trees.composites.Sequence("Route", memory=True, children=[
        py_trees.behaviours.Success("A"), py_trees.behaviours.Running("B")])
    state = TreeState.of_tree(root)
    groot = Groot2Server.for_tree(root, "Route", port=free_port_pair(),
                                  blackboard=lambda _: {"target": "red"})
    source = LiveSource("127.0.0.1", groot.port)
    try:
        assert source.tree == {"names": ["Route", "A", "B"], "parents": [-1, 0, 0],
                               "kinds": ["sequence", "leaf", "leaf"]}
        root.tick_once()
        state.capture()
        groot.tick(0.0, None, None, state)
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not any(
                t["nodes"].get("2") == ["RUNNING", ""] for t in source.ticks(0)):
            time.sleep(0.05)
        last = {}
        for t in source.ticks(0):
            last.update(t["nodes"])
        assert last == {"0": ["RUNNING", ""], "1": ["SUCCESS", ""], "2": ["RUNNING", ""]}
        assert source.ticks(0)[-1]["bb"] == {"target": "red"}
    finally:
        source.close()
        groot.close()


def _browser() -> Any:
    webdriver = pytest.importorskip("selenium.webdriver")
    chromium, driver = shutil.which("chromium"), shutil.which("chromedriver")
    if chromium is None or driver is None:
        pytest.skip("needs Debian's chromium and chromium-driver (.ci/run installs them)")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--window-size=1280,900"):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(driver), options=options)


def _wait(browser: Any, script: str, timeout_s: float = 10.0) -> Any:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = browser.execute_script(script)
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for: {script}")


def _statuses(browser: Any) -> list[str]:
    return list(browser.execute_script(
        "return [...document.querySelectorAll('#tree .node')]"
        ".map(n => n.className.replace('node ', ''))"))


def test_in_a_browser_the_tree_is_drawn_and_the_timeline_moves_it(tmp_path: Path) -> None:
    server = TreePageServer(LogSource(_records())).start()
    browser = _browser()
    try:
        browser.get(server.url)
        _wait(browser, "return document.body.dataset.ready === '1'")
        names = browser.execute_script(
            "return [...document.querySelectorAll('#tree .node .name')].map(n => n.textContent)")
        assert names == TREE["names"]
        assert _statuses(browser) == ["RUNNING", "RUNNING", "INVALID"]  # tick 0
        for k, expected in ((1, ["RUNNING", "SUCCESS", "RUNNING"]),
                            (2, ["SUCCESS", "SUCCESS", "SUCCESS"]),
                            (0, ["RUNNING", "RUNNING", "INVALID"])):
            browser.execute_script(
                "const s = document.getElementById('timeline');"
                f"s.value = '{k}'; s.dispatchEvent(new Event('input'));")
            _wait(browser, f"return document.body.dataset.shown === '{k}'")
            assert _statuses(browser) == expected, k
        browser.execute_script(
            "const s = document.getElementById('timeline');"
            "s.value = '1'; s.dispatchEvent(new Event('input'));")
        board = browser.find_element("id", "blackboard").text
        assert "/marknav/target" in board and "red" in board
        assert "closing" not in browser.find_element("id", "tree").text  # tick 1's messages
        assert "curve 1" in browser.find_element("id", "tree").text
        assert browser.get_screenshot_as_file(str(tmp_path / "page.png"))
    finally:
        browser.quit()
        server.close()


def test_serve_tree_needs_a_run_or_live(capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["serve-tree"]) == 2
    assert "RUN or --live" in capsys.readouterr().err


def test_serve_tree_live_without_a_server_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("zmq")
    from marknav.cli.main import main

    assert main(["serve-tree", "--live", str(free_port_pair()), "--port", "0"]) == 2
    assert "no Groot2 server answered" in capsys.readouterr().err
