"""UFF time records onto a small rig through the API: the ways a record finds its sensor (UFF
node and direction, name, order), the force record (newtons, the others' reference), units (V
through the rig's sensitivity, g to m/s^2) and what is refused."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from odsuite.domain.errors import ConfigError
from odsuite.analysis.modal_project import physical
from odsuite.contracts.plugins import registries
from odsuite.store.project import create_project, open_project
from odsuite.domain.rig import load_rig
from odsuite_plugins.importers.tables import G
from odsuite_plugins.importers.uff import time_function, write_uff
from odsuite_plugins.importers.uff_project import import_uff, rig_nodes

RIG = """
name = "bench"
[[bodies]]
name = "plate"
mass = 3.0
inertia = [[0.02, 0, 0], [0, 0.03, 0], [0, 0, 0.05]]
plate = { size = [0.3, 0.2, 0.01], corner = [-0.15, -0.1, 0.0] }
[[sensors]]
name = "hammer"
kind = "force"
channel = 0
sensitivity = 0.002
[[sensors]]
name = "tri"
kind = "triaxial_accelerometer"
body = "plate"
position = [0.05, 0.0, 0.0]
channels = [1, 2, 3]
sensitivity = [0.01, 0.02, 0.04]
"""
N = 64
#: a distinct signal per record, so that a record on the wrong channel shows
SIGNALS = {k: np.sin(np.arange(N) * (k + 1) / 7.0) * (k + 1) for k in range(4)}
Z_UP = np.array([0.0, 0.0, 1.0])


def _project(tmp_path, text=RIG):
    (tmp_path / "rig.toml").write_text(text)
    rig = load_rig(tmp_path / "rig.toml", registries().sensor_types)
    create_project(tmp_path / "p.h5", rig=rig).close()
    return tmp_path / "p.h5", rig


def _write(tmp_path, records) -> object:
    """``records``: (name, signal index, unit, node, direction, scale)."""
    path = tmp_path / "r.uff"
    write_uff(path, functions=[time_function(name, SIGNALS[k] * scale, 1e-3, unit, node=node, direction=d)
                               for name, k, unit, node, d, scale in records], overwrite=True)
    return path


def _stored(p):
    with open_project(p) as proj:
        exp = proj.experiment("r")
        return physical(exp), exp.excitation


def test_by_node_with_the_force_at_the_reference_and_volts_through_the_sensitivities(tmp_path):
    p, rig = _project(tmp_path)
    at = rig_nodes(rig)[2]  # export-uff's numbering: the plate's four corners, then the sensor's node
    node = at[1][0]
    assert node == 5 and [at[c] for c in (1, 2, 3)] == [(5, 1), (5, 2), (5, 3)]
    path = tmp_path / "r.uff"
    # y against the sensor's axis (-2): values negated; the force record named by nothing but being
    # the reference node of the others
    functions = [time_function("f", SIGNALS[0] * 0.002, 1e-3, "V", node=40, direction=3)]
    for k, (d, sens) in enumerate([(1, 0.01), (-2, 0.02), (3, 0.04)], start=1):
        f = time_function(f"r{k}", SIGNALS[k] * sens * np.sign(d), 1e-3, "V", node=node, direction=d)
        functions.append(replace(f, ref_node=40, ref_dir=3))
    write_uff(path, functions=functions)
    summary, _ = import_uff(p, path, "r", force_point=np.zeros(3), force_dir=Z_UP)
    assert "by UFF node" in summary
    data, excitation = _stored(p)
    for k in range(4):
        np.testing.assert_allclose(data[:, k], SIGNALS[k], rtol=1e-12, atol=1e-12)
    assert excitation.force_channel == 0


def test_by_name_and_g_converted(tmp_path):
    p, _ = _project(tmp_path)
    path = _write(tmp_path, [("tri_z", 3, "g", 0, 0, 1 / G), ("Tri X", 1, "m/s^2", 0, 0, 1.0),
                             ("hammer", 0, "N", 0, 0, 1.0)])
    summary, notes = import_uff(p, path, "r", force_point=np.zeros(3), force_dir=Z_UP)
    assert "by name" in summary
    data, _ = _stored(p)
    for k in (0, 1, 3):
        np.testing.assert_allclose(data[:, k], SIGNALS[k], rtol=1e-12, atol=1e-12)
    assert not data[:, 2].any() and any("tri_y" in n and "not recorded" in n for n in notes)


def test_by_order_says_so(tmp_path):
    p, _ = _project(tmp_path)
    path = _write(tmp_path, [("F", 0, "N", 0, 0, 1.0)] + [(f"a{k}", k, "m/s^2", 0, 0, 1.0) for k in (1, 2, 3)])
    summary, notes = import_uff(p, path, "r", force_point=np.zeros(3), force_dir=Z_UP)
    assert "by order" in summary and any("in order" in n for n in notes)
    data, _ = _stored(p)
    np.testing.assert_allclose(data, np.column_stack([SIGNALS[k] for k in range(4)]), rtol=1e-12, atol=1e-12)


def test_a_response_at_the_reference_is_never_stored_as_the_force(tmp_path):
    p, _ = _project(tmp_path)
    functions = [time_function("a1", SIGNALS[1], 1e-3, "m/s^2", node=5, direction=1),
                 time_function("a3", SIGNALS[3], 1e-3, "m/s^2", node=5, direction=3)]
    functions[0] = replace(functions[0], ref_node=5, ref_dir=3)
    write_uff(tmp_path / "r.uff", functions=functions)
    with pytest.raises(ConfigError, match=r"time record 'a3' is in 'm/s\^2' \(acceleration\), but rig 'bench' "
                                          r"channel 0 measures force"):
        import_uff(p, tmp_path / "r.uff", "r", force_point=np.zeros(3), force_dir=Z_UP)
    with open_project(p) as proj:
        assert proj.experiment_names() == []


def test_two_sensors_on_one_line_at_a_declared_node_are_refused(tmp_path):
    text = RIG + """
[[sensors]]
name = "single"
body = "plate"
position = [0.05, 0.0, 0.0]
axis = [0.0, 0.0, -1.0]
channel = 4
sensitivity = 0.01
"""
    p, rig = _project(tmp_path, text)
    with pytest.raises(ConfigError, match="sensors 'tri_z' and 'single' measure along one line at UFF node 5"):
        rig_nodes(rig)
