"""UFF 58 time records imported onto a rig's sensors, through the command line: files written by
pyuff directly (not odsuite's exporter) from the simulated two-body machine's signals, in volts and
in m/s^2, matched by UFF node and direction (the rig file declaring `uff_node` per sensor); and
odsuite's own export read back onto the same rig."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from odsuite.cli import main
from odsuite.analysis.modal_project import physical
from odsuite.store.project import open_project

pytestmark = pytest.mark.slow
RIGS = Path(__file__).resolve().parents[2] / "projects" / "rigs"
#: UFF node per triaxial accelerometer of the two-body machine, as a lab would number its points
NODES = {"b1": 11, "b2": 12, "b3": 13, "m1": 21, "m2": 22, "m3": 23}
HAMMER_NODE = 99
#: records written against the sensor's axis (negative direction code, values negated)
FLIPPED = {"b2_x", "b2_y", "b2_z", "m1_z"}
#: two blows: force point (mm, rig frame), direction
BLOWS = [("50,20,250", "-z"), ("-150,0,130", "+x")]


def run(*args) -> None:
    assert main([str(a) for a in args]) == 0


def _rig_with_nodes(folder: Path) -> Path:
    text = (RIGS / "two-body-machine.toml").read_text()
    for name, node in NODES.items():
        assert text.count(f'name = "{name}"\n') == 1
        text = text.replace(f'name = "{name}"\n', f'name = "{name}"\nuff_node = {node}\n')
    path = folder / "machine.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """A simulated two-body project (the rig file with UFF nodes) with two blows."""
    d = tmp_path_factory.mktemp("uff-rig")
    rig = _rig_with_nodes(d)
    p = d / "source.h5"
    run("new", p, "--rig", rig)
    for k, (point, direction) in enumerate(BLOWS):
        run("acquire", p, "--name", f"b{k}", f"--force-point={point}", f"--force-dir={direction}", "--seed", k + 1,
            "--samples", 4096)
    return d, rig, p


def _source(p: Path, name: str):
    with open_project(p) as proj:
        exp = proj.experiment(name)
        return (physical(exp), exp.sampling_rate, exp.excitation, list(exp.channel_names), proj.rig)


def _code(direction: np.ndarray) -> int:
    k = int(np.argmax(np.abs(direction)))
    return int(np.sign(direction[k])) * (k + 1)


def _write_pyuff(path: Path, p: Path, name: str, *, volts: bool) -> None:
    """The experiment's channels as pyuff 58b time records: responses at their sensor's node
    (direction 1, 2, 3 = the triaxial's x, y, z; FLIPPED ones negative with negated values) naming
    the hammer's node as reference, the force at the hammer's node; in V (sensor volts: the SI value
    times the rig's sensitivity) or in m/s^2 and N. The m/s^2 file also holds the hammer's node
    and the sensors' nodes (dataset 15), so that the force point and direction come from the file."""
    import pyuff

    data, fs, excitation, names, rig = _source(p, name)
    ref_dir = _code(excitation.direction)
    sets = []
    if not volts:  # the lab's nodes (m, rig frame): each triaxial accelerometer's point and the hammer's
        xyz = np.array([rig.sensor(f"{g}_x").position for g in NODES] + [excitation.point])
        nums = [*NODES.values(), HAMMER_NODE]
        sets.append(pyuff.prepare_15(node_nums=nums, def_cs=[0] * len(nums), disp_cs=[0] * len(nums),
                                     color=[8] * len(nums), x=xyz[:, 0], y=xyz[:, 1], z=xyz[:, 2],
                                     return_full_dict=True))
    for s in [rig.sensor_on_channel(rig.force_channel), *rig.accelerometers]:
        values = data[:, s.channel] * (s.sensitivity if volts else 1.0)
        if s.quantity == "force":
            node, direction, label = HAMMER_NODE, ref_dir, "impact"  # not the rig's sensor name
            unit = "V" if volts else "N"
        else:
            node, direction = NODES[s.group], "xyz".index(s.name[-1]) + 1
            if s.name in FLIPPED:
                direction, values = -direction, -values
            label, unit = f"point {node} dir {direction}", "V" if volts else "m/s^2"
        sets.append(pyuff.prepare_58(
            binary=1, id1=label, id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1, ver_num=0,
            load_case_id=0, rsp_ent_name="NONE", rsp_node=node, rsp_dir=direction, ref_ent_name="NONE",
            ref_node=HAMMER_NODE, ref_dir=ref_dir, ord_data_type=4, num_pts=values.size, abscissa_spacing=1,
            abscissa_min=0.0, abscissa_inc=1.0 / fs, z_axis_value=0.0, abscissa_spec_data_type=17,
            abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
            abscissa_axis_units_lab="s", ordinate_spec_data_type={"V": 0, "N": 13, "m/s^2": 12}[unit],
            ordinate_len_unit_exp=0, ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
            ordinate_axis_units_lab=unit, orddenom_spec_data_type=0, orddenom_len_unit_exp=0,
            orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0, orddenom_axis_units_lab="NONE",
            z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
            z_axis_axis_units_lab="NONE", data=np.ascontiguousarray(values), x=np.arange(values.size) / fs,
            return_full_dict=True))
    path.write_bytes(b"")  # pyuff appends
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


@pytest.mark.parametrize("volts", [True, False], ids=["volts", "m_s2"])
def test_pyuff_records_land_on_the_rig_sensors(source, tmp_path, volts):
    d, rig, src = source
    p = tmp_path / "imported.h5"
    run("new", p, "--rig", rig)
    for k, (point, direction) in enumerate(BLOWS):
        uff = tmp_path / f"b{k}.uff"
        _write_pyuff(uff, src, f"b{k}", volts=volts)
        # volts: the force record is told by being the others' reference; the hammer point given here.
        # m/s^2: the force record is in N, its point and direction read from the file's node
        extra = [f"--force-point={point}", f"--force-dir={direction}"] if volts else []
        run("import-uff", p, uff, "--name", f"b{k}", *extra)
    for k in range(len(BLOWS)):
        want, fs, excitation, _, r = _source(src, f"b{k}")
        got, fs2, excitation2, names, _ = _source(p, f"b{k}")
        assert fs2 == fs and got.shape == want.shape
        # every accelerometer (the flipped ones included) and the force, in SI, to numeric precision
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
        with open_project(p) as proj:
            exp = proj.experiment(f"b{k}")
            raw = exp.raw()
            assert exp.systeminfo.channels[r.force_channel].unit == "N"
            if volts:  # the file's volts are stored as they are, converted by the rig's sensitivities
                for s in r.accelerometers:
                    np.testing.assert_allclose(raw[:, s.channel], want[:, s.channel] * s.sensitivity, rtol=1e-12,
                                               atol=1e-15)
        assert excitation2.force_channel == r.force_channel
        np.testing.assert_allclose(excitation2.point, excitation.point, atol=1e-9)
        np.testing.assert_allclose(excitation2.direction, excitation.direction, atol=1e-12)
        assert names[r.sensor("b2_x").channel] == f"point {NODES['b2']} dir -1"  # the record's own name


def test_a_perfect_model_on_imported_records_is_at_the_noise_floor(source, tmp_path, capsys):
    d, rig, src = source
    p = tmp_path / "imported.h5"
    assert main(["new", str(p), "--rig", str(rig)]) == 0
    for k in range(len(BLOWS)):
        uff = tmp_path / f"b{k}.uff"
        _write_pyuff(uff, src, f"b{k}", volts=False)
        assert main(["import-uff", str(p), str(uff), "--name", f"b{k}"]) == 0
    assert main(["process", str(p)]) == 0
    capsys.readouterr()
    assert main(["compare", str(p), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["error"] <= 1.5 * result["noise_floor"], (result["error"], result["noise_floor"])


def test_odsuite_export_reads_back_onto_the_same_rig(source, tmp_path, capsys):
    """export-uff -> import-uff onto a project on the same rig: the same channels, names, units
    and hammer blow, with no option given (nodes and the hammer's node come from the file)."""
    d, rig, src = source
    for rig_file in (rig, RIGS / "two-body-machine.toml"):  # declared nodes, and export's own numbering
        p = tmp_path / f"{rig_file.stem}.h5"
        ref = tmp_path / f"{rig_file.stem}-src.h5"
        assert main(["new", str(p), "--rig", str(rig_file)]) == 0
        assert main(["new", str(ref), "--rig", str(rig_file)]) == 0
        assert main(["acquire", str(ref), "--name", "b0", f"--force-point={BLOWS[0][0]}",
                     f"--force-dir={BLOWS[0][1]}", "--seed", "5", "--samples", "2048"]) == 0
        uff = tmp_path / f"{rig_file.stem}.uff"
        assert main(["export-uff", str(ref), "b0", "-o", str(uff)]) == 0
        capsys.readouterr()
        assert main(["import-uff", str(p), str(uff), "--name", "b0"]) == 0
        assert "onto rig 'two-body-machine' (by UFF node)" in capsys.readouterr().out
        want, fs, excitation, names, r = _source(ref, "b0")
        got, fs2, excitation2, names2, _ = _source(p, "b0")
        np.testing.assert_array_equal(got, want)
        assert fs2 == fs and names2 == names
        assert excitation2.force_channel == excitation.force_channel
        np.testing.assert_allclose(excitation2.point, excitation.point, atol=1e-9)
        np.testing.assert_array_equal(excitation2.direction, excitation.direction)
        with open_project(p) as a, open_project(ref) as b:
            assert ([c.unit for c in a.experiment("b0").systeminfo.channels]
                    == [c.unit for c in b.experiment("b0").systeminfo.channels])
