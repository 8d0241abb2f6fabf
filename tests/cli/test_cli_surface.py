"""The command line as a user meets it: --version, shell completion, help without type clutter,
--json on the commands that report, and the force point checked against the rig's bodies."""

from __future__ import annotations

import json

import pytest

from odsuite import cli
from odsuite.cli import main
from odsuite.domain.version import __version__
from tests.cli.clirun import run


@pytest.fixture(autouse=True)
def wide_console(monkeypatch):
    monkeypatch.setattr(cli.console, "width", 200)


def test_version_and_completion(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out.strip() == f"odsuite {__version__}"
    code, out, _ = run(capsys, "--help")
    assert code == 0 and "--install-completion" in out and "--show-completion" in out


@pytest.mark.parametrize("command", [None, "render", "acquire", "report", "compare", "info", "frf"])
def test_help_shows_no_type_for_flags(capsys, command):
    code, out, _ = run(capsys, *([command] if command else []), "--help")
    assert code == 0 and "<bool>" not in out and "--help" in out


@pytest.fixture(scope="module")
def sim_project(tmp_path_factory):
    p = tmp_path_factory.mktemp("surface") / "p.h5"
    assert main(["new", str(p)]) == 0
    assert main(["acquire", str(p), "--daq", "sim", "--name", "T1", "--scenario", "T1", "--seed", "1",
                 "--samples", "2048", "--force-peak", "8"]) == 0
    return p


def test_json_documents(sim_project, capsys):
    code, out, _ = run(capsys, "info", sim_project, "--json")
    info = json.loads(out)
    assert code == 0 and info["experiments"]["T1"]["n_samples"] == 2048
    code, out, _ = run(capsys, "verify", sim_project, "--json")
    doc = json.loads(out)
    assert code == 0 and doc["intact"] and doc["experiments"]["T1"] == doc["datasets"] > 0
    code, out, _ = run(capsys, "plugins", "--json")
    plugins = json.loads(out)["plugins"]
    sim = next(p for p in plugins.values() if "sim" in p["daq_backend_options"])
    assert {"flag": "--force-peak", "type": "float"} in sim["daq_backend_options"]["sim"]
    assert any("report" in p["registers"].get("renderers", []) for p in plugins.values())
    code, out, _ = run(capsys, "frf", sim_project, "--experiment", "T1", "--json")
    frf = json.loads(out)
    assert code == 0 and len(frf["hits"]) == 1 and frf["hits"][0]["accepted"]
    # the 8 N hammer seen through the force channel's anti-alias filter: a little below 8 N
    assert 4.0 < frf["hits"][0]["peak_force_n"] < 8.0


def test_info_and_history_give_the_same_errors(sim_project, capsys):
    code, out, _ = run(capsys, "history", sim_project, "--json")
    hist = json.loads(out)
    code, out, _ = run(capsys, "info", sim_project, "--json")
    info = json.loads(out)
    assert [r["error"] for r in info["model_revisions"]] == [r["error"] for r in hist["revisions"]]
    assert hist["revisions"][0]["error"] is not None and hist["noise_floor_error"] > 0
    code, out, _ = run(capsys, "info", sim_project)
    assert f"{hist['revisions'][0]['error']:.4f}" in out


def test_force_point_off_every_body_is_refused_in_one_line(sim_project, capsys):
    # the thesis platform is 98 x 170 x 22 mm; 0.5 m off along x is past even the 0.5 m reference plate
    code, out, err = run(capsys, "acquire", sim_project, "--daq", "sim", "--name", "off",
                         "--force-point=500,0,0", "--force-dir=+z")
    assert code == 1 and err.strip().count("\n") == 0
    assert "outside every body" in err and "the nearest moving body, 'platform', is 451.6 mm away" in err
    code, _, err = run(capsys, "info", sim_project, "--json")
    assert "off" not in json.loads(_)["experiments"]


def test_diagnose_reads_at_80_columns(sim_project, capsys, monkeypatch):
    """At 80 columns (a terminal, or piped), the candidates' table keeps one line per candidate and
    the evidence reads as wrapped paragraphs, not one word per line."""
    monkeypatch.setattr(cli.console, "width", 80)
    code, out, _ = run(capsys, "diagnose", sim_project, "--effect", "stiffness", "--effect", "damping",
                       "--effect", "sensor_gain")
    lines = out.splitlines()
    assert code == 0 and max(len(line) for line in lines) <= 80
    rows = [line for line in lines if line.startswith("│")]
    assert len(rows) == 3 and {r.split("│")[1].strip() for r in rows} == {"stiffness", "damping", "sensor_gain"}
    assert len(lines) < 40
