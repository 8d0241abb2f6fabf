"""Sensor types through their registry: a rig file's [[sensors]] kinds, triaxial accelerometers,
a lab's own kind, and the solver each body gets from the sensors it carries."""

from __future__ import annotations

import numpy as np
import pytest

from odsuite import hookimpl
from odsuite.domain.errors import ConfigError
from odsuite.contracts.plugins import build_registries, make_plugin_manager
from odsuite.domain.rig import rig_from_dict, single_axis_sensor
from odsuite.contracts.solvers import choose_solver

#: a 12 kg block, three triaxial accelerometers at three corners (tilted axes on the third)
TILT = np.array([[np.cos(0.3), np.sin(0.3), 0.0], [-np.sin(0.3), np.cos(0.3), 0.0], [0.0, 0.0, 1.0]])


def block(triaxials: int = 3, **extra) -> dict:
    corners = [[0.1, 0.05, 0.02], [-0.1, 0.05, 0.02], [0.1, -0.05, -0.02]]
    sensors = [{"name": f"t{k}", "kind": "triaxial_accelerometer", "body": "block", "position": corners[k],
                "channels": [1 + 3 * k, 2 + 3 * k, 3 + 3 * k], "sensitivity": [0.01, 0.0102, 0.0098],
                **({"axes": TILT.tolist()} if k == 2 else {})} for k in range(triaxials)]
    return {"name": "block-rig", "force_channel": 0,
            "bodies": [{"name": "block", "mass": 12.0, "inertia": np.diag([0.05, 0.08, 0.1]).tolist(),
                        "com": [0.0, 0.0, 0.0], **extra}],
            "sensors": sensors}


def test_triaxial_expands_into_three_single_axis_sensors(registries):
    rig = rig_from_dict(block(), registries.sensor_types)
    assert [s.name for s in rig.sensors][:3] == ["t0_x", "t0_y", "t0_z"]
    t2 = [s for s in rig.sensors if s.group == "t2"]
    assert [s.channel for s in t2] == [7, 8, 9]
    assert np.allclose([s.axis for s in t2], TILT)
    assert [s.sensitivity for s in t2] == [0.01, 0.0102, 0.0098]
    assert all(s.kind == "accelerometer" and s.quantity == "acceleration" for s in rig.sensors)


@pytest.mark.parametrize("change, words", [
    (lambda d: d["sensors"][0].update(kind="triax"), ["sensors[0] 't0'", "field 'kind'", "'triax'",
                                                      "triaxial_accelerometer"]),
    (lambda d: d["sensors"][1].update(channels=[4, 5]), ["sensors[1] 't1'", "field 'channels'", "[4, 5]"]),
    (lambda d: d["sensors"][2].update(axes=[[1, 0, 0], [1, 0, 0], [0, 0, 1]]), ["sensors[2] 't2'", "field 'axes'",
                                                                            "not independent"]),
    (lambda d: d["sensors"][0].update(body="frame"), ["sensors[0] 't0'", "field 'body'", "'frame'"]),
    (lambda d: d["sensors"][1].update(channels=[1, 5, 6]), ["two sensors share a channel", "'t0_x' and 't1_x'",
                                                            "field 'channel'", "both 1"]),
    # a misspelt field would be ignored and its default used (a sensitivity lost, a serial dropped)
    (lambda d: d["sensors"][1].update(serail="A-1"), ["sensors[1] 't1'", "unknown field 'serail'",
                                                      "did you mean 'serial'"]),
    (lambda d: d["sensors"][1].update(channel=4), ["sensors[1] 't1'", "unknown field 'channel'",
                                                   "did you mean 'channels'"]),
    (lambda d: d["sensors"].append({"name": "hammer", "kind": "force", "channel": 0, "sensitivty": 0.00225}),
     ["sensors[3] 'hammer'", "unknown field 'sensitivty'", "did you mean 'sensitivity'"]),
    (lambda d: d.update(acquisiton={"sampling_rate": 5000.0}), ["unknown field 'acquisiton'",
                                                                "did you mean 'acquisition'"]),
])
def test_bad_sensor_entries_are_one_line(registries, change, words):
    data = block()
    change(data)
    with pytest.raises(ConfigError) as err:
        rig_from_dict(data, registries.sensor_types)
    msg = str(err.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_a_labs_sensor_type_is_read_from_rig_files():
    class StrainGauge:
        name, quantity, unit, description = "lab_strain", "strain", "1", "a strain gauge"

        def sensors(self, entry, where):
            return [single_axis_sensor(entry, where, kind=self.name, quantity=self.quantity)]

    class Lab:
        __name__ = "lab_gauges"

        @hookimpl
        def odsuite_register_sensor_types(self, registry):
            registry.add("lab_strain", StrainGauge())

    regs = build_registries(make_plugin_manager(extra_plugins=(Lab(),)))
    data = block()
    data["sensors"].append({"name": "g1", "kind": "lab_strain", "body": "block", "channel": 10,
                            "position": [0, 0, 0.02], "axis": [1, 0, 0], "sensitivity": 2.0})
    rig = rig_from_dict(data, regs.sensor_types)
    gauge = rig.sensor("g1")
    assert (gauge.kind, gauge.quantity, gauge.channel) == ("lab_strain", "strain", 10)
    assert regs.sensor_types.entry("lab_strain").plugin == "lab_gauges"


def test_three_triaxials_get_least_squares_and_recover_a_rigid_motion(registries):
    """Independent reference: sensor i reads a_i . (t + theta x r_i) for a small rigid motion."""
    rig = rig_from_dict(block(), registries.sensor_types)
    body = rig.body("block")
    chosen = choose_solver(rig, body, [s.name for s in rig.sensors], registries.coordinate_solvers)
    assert chosen.name == "least-squares"
    rng = np.random.default_rng(7)
    d = rng.normal(scale=1e-5, size=(50, 6))
    signals = {s.name: d[:, :3] @ s.axis + np.cross(d[:, 3:], s.position - body.com) @ s.axis for s in rig.sensors}
    res = chosen.solver.solve(rig, body, signals)
    assert np.max(np.abs(res.at_g - d)) < 1e-9 * np.max(np.abs(d))


def test_a_body_whose_sensors_miss_a_rotation_is_named_with_its_directions(registries):
    """Two triaxial points cannot see the rotation about the line joining them."""
    rig = rig_from_dict(block(triaxials=2), registries.sensor_types)
    with pytest.raises(ConfigError) as err:
        choose_solver(rig, rig.body("block"), [s.name for s in rig.sensors], registries.coordinate_solvers)
    msg = str(err.value)
    assert "body 'block'" in msg and "t0_x along [1.0, 0.0, 0.0]" in msg and "six independent directions" in msg


def test_a_solver_named_in_the_rig_file_is_used_or_refused(registries):
    rig = rig_from_dict(block(solver="least-squares"), registries.sensor_types)
    names = [s.name for s in rig.sensors]
    assert choose_solver(rig, rig.body("block"), names, registries.coordinate_solvers).name == "least-squares"
    rig = rig_from_dict(block(solver="padgaonkar-nine"), registries.sensor_types)
    with pytest.raises(ConfigError, match=r"field 'solver': 'padgaonkar-nine' cannot solve the body"):
        choose_solver(rig, rig.body("block"), names, registries.coordinate_solvers)
    rig = rig_from_dict(block(solver="magic"), registries.sensor_types)
    with pytest.raises(ConfigError, match=r"field 'solver': unknown coordinate solver 'magic' \(known: "):
        choose_solver(rig, rig.body("block"), names, registries.coordinate_solvers)


def test_a_project_keeps_triaxials_springs_and_dofs_without_the_rig_file(registries, tmp_path):
    from odsuite import open_project
    from odsuite.store.h5codecs import rig_to_dict
    from odsuite.store.project import create_project

    data = block()
    data["bodies"][0]["dofs"] = ["x", "y", "z", "psi"]
    data["springs"] = [{"name": "mount", "body": "block", "position": [0, 0, 0.05], "group": "mounts",
                        "stiffness": [[2e5, 1e4, 0], [1e4, 3e5, 0], [0, 0, 4e5]], "damping": [10, 10, 20]}]
    rig = rig_from_dict(data, registries.sensor_types)
    create_project(tmp_path / "p.h5", rig=rig).close()
    with open_project(tmp_path / "p.h5") as p:
        back = p.rig
    assert rig_to_dict(back) == rig_to_dict(rig)
    assert back.body("block").dofs == ("x", "y", "z", "psi")
    assert back.springs[0].group == "mounts" and back.springs[0].stiffness.shape == (3, 3)
    assert [s.group for s in back.sensors].count("t2") == 3
