"""``marknav tree MISSION --xml``: BehaviorTree.CPP XML on standard output or in a file, the
schema beside it, and bad options refused with exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from marknav.cli.main import main
from marknav.runs.records.btcpp import read_tree_xml

etree = pytest.importorskip("lxml.etree")


def test_xml_on_stdout_is_the_tree_alone(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tree", "slalom", "--xml", "-"]) == 0
    out = capsys.readouterr().out
    back = read_tree_xml(out)
    assert back["id"] == "slalom"
    assert back["names"][:3] == ["Mission", "Perception", "SafetyGuard"]
    assert back["uids"] == list(range(1, len(back["names"]) + 1))


def test_plain_xml_file_validates_against_the_written_schema(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    xml, xsd = tmp_path / "slalom.xml", tmp_path / "slalom.xsd"
    assert main(["tree", "slalom", "--xml", str(xml), "--plain", "--xsd", str(xsd)]) == 0
    out = capsys.readouterr().out
    assert f"# wrote {xml}" in out and f"# wrote {xsd}" in out
    schema = etree.XMLSchema(etree.parse(str(xsd)))
    assert schema.validate(etree.parse(str(xml))), schema.error_log
    assert "_uid" not in xml.read_text()


def test_plain_without_xml_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tree", "slalom", "--plain"]) == 2
    assert "--plain" in capsys.readouterr().err


def test_unwritable_xml_path_is_refused_before_the_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["tree", "slalom", "--xml", str(tmp_path / "no" / "such" / "t.xml")]) == 2
    assert "--xml" in capsys.readouterr().err
