"""A rig stored in a project reads back with everything its file said: processing tables (rig-wide
and per sensor) and the upward direction."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odsuite.store.project import create_project, open_project
from odsuite.domain.systeminfo import Systeminfo

RIGS = Path(__file__).resolve().parents[2] / "projects" / "rigs"
#: the thesis rig and its Systeminfo ship once, with the models plugin that registers them
PLUGIN_RIGS = Path(__file__).resolve().parents[2] / "plugins" / "models" / "rigs"


def test_processing_and_up_survive_the_project(tmp_path):
    text = (RIGS / "two-body-machine.toml").read_text().replace(
        'sensitivity = 0.00225', 'sensitivity = 0.00225\nprocessing = { filter = { type = "lowpass", cutoff_hz = 2000.0 }, '
        'filter_at = ["signal"] }', 1)
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text(text)
    create_project(tmp_path / "p.h5", str(rig_file)).close()
    with open_project(tmp_path / "p.h5") as p:
        rig = p.rig
    assert rig.processing["cutoff_low"] == 4.0 and rig.processing["filter_order"] == 4
    si = Systeminfo.for_rig(rig, 10240.0)
    assert si.channels[0].cutoff_high == 2000.0 and si.channels[0].filters_on == 1
    assert si.channels[1].cutoff_low == 4.0
    assert np.allclose(rig.up, [0, 0, 1])  # the default: the file says nothing


def test_the_thesis_rig_keeps_its_downward_z(tmp_path):
    create_project(tmp_path / "p.h5", "thesis-dynamometer").close()
    with open_project(tmp_path / "p.h5") as p:
        assert np.allclose(p.rig.up, [0, 0, -1])


def _stored_without_up(tmp_path, text: str, *, as_toml: bool) -> Path:
    """A project written as earlier versions did: the rig's JSON without ``up`` beside the rig file's
    text (``as_toml``: the oldest layout, the file's text as the definition itself)."""
    import json

    import h5py

    from odsuite.store import h5text

    rig_dir = tmp_path / "rig"
    rig_dir.mkdir()
    (rig_dir / "thesis-dynamometer.toml").write_text(text, encoding="utf-8")
    (rig_dir / "thesis-table-e3.CTR").write_bytes((PLUGIN_RIGS / "thesis-table-e3.CTR").read_bytes())
    path = tmp_path / "old.h5"
    create_project(path, str(rig_dir / "thesis-dynamometer.toml")).close()
    with h5py.File(path, "a") as f:
        a = f["rig"].attrs
        definition = json.loads(h5text.text(a["definition"]))
        del definition["up"]
        attrs = {"definition": text, "definition_format": "toml", "source_text": ""} if as_toml else \
            {"definition": json.dumps(definition), "definition_format": "json"}
        h5text.set_attrs(f["rig"], attrs)
    return path


def test_an_old_thesis_project_without_up_draws_z_down(tmp_path):
    """The thesis rig file as released before ``up`` (today's text without its ``up`` line, SHA-256
    258506ce...): a project made from it is recognised by that stored text and keeps z down."""
    current = (PLUGIN_RIGS / "thesis-dynamometer.toml").read_text(encoding="utf-8")
    released = "".join(ln for ln in current.splitlines(keepends=True) if not ln.startswith("up = "))
    assert released != current
    for as_toml in (False, True):
        sub = tmp_path / ("toml" if as_toml else "json")
        sub.mkdir()
        with open_project(_stored_without_up(sub, released, as_toml=as_toml)) as p:
            assert np.allclose(p.rig.up, [0, 0, -1]), as_toml


def test_an_edited_copy_without_up_keeps_the_default(tmp_path):
    """Any other text (here the released file with one comment added) is not the thesis rig as
    shipped: nothing says which way is up, so z is up."""
    current = (PLUGIN_RIGS / "thesis-dynamometer.toml").read_text(encoding="utf-8")
    edited = "# my copy\n" + "".join(ln for ln in current.splitlines(keepends=True) if not ln.startswith("up = "))
    with open_project(_stored_without_up(tmp_path, edited, as_toml=False)) as p:
        assert np.allclose(p.rig.up, [0, 0, 1])
