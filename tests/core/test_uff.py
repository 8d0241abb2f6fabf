"""UFF import/export through pyuff: the pyuff sample files (values listed in their README) and
lossless round trips of our own exports."""

from __future__ import annotations

import numpy as np
import pytest
import pyuff

from odsuite.domain.errors import ConfigError
from odsuite_plugins.importers.uff import (
    UffFunction,
    UffGeometry,
    read_uff,
    time_function,
    write_uff,
)


@pytest.fixture
def samples(real_data):
    return real_data / "pyuff_uff_samples"


def test_time_record_ascii_and_binary_58b(samples):
    a = read_uff(samples / "Sample_UFF58_ascii.uff").functions[0]
    b = read_uff(samples / "Sample_UFF58b_bin.uff").functions[0]
    for f in (a, b):
        assert f.name == "Mic 01.0Scalar" and f.rsp_dir == 1 and f.is_time and f.unit == "Pa"
        assert f.data.size == 79292
        assert f.data[0] == pytest.approx(-1.47553e-2, rel=1e-5)
        assert f.data[-1] == pytest.approx(-4.31469e-3, rel=1e-5)
        np.testing.assert_allclose(f.x, np.arange(f.data.size) * f.x[1])
        assert f.x[1] == pytest.approx(1.52588e-5)
    np.testing.assert_allclose(a.data, b.data, rtol=1e-5, atol=1e-9)


def test_frf_non_ascii_header_and_8_byte_binary(samples):
    f = read_uff(samples / "non_ascii_header.uff").functions[0]
    assert f.name == "ref6_23_Mar" and f.rsp_dir == 0 and f.func_type == 4
    assert f.data[0] == pytest.approx(0.407994 + 0j, rel=1e-5)
    assert f.data[-1] == pytest.approx(3.75037 + 2.93363j, rel=1e-5)
    assert f.x[1] - f.x[0] == pytest.approx(0.195313, rel=1e-5)
    s = read_uff(samples / "binary8byte.uff").functions[0]
    assert s.data.size == 250
    assert s.x[1] == pytest.approx(0.01)
    # the README says sin(2 pi t); the samples are a 5 Hz sine (20 samples a period), single precision
    np.testing.assert_allclose(s.data, np.sin(2 * np.pi * 5 * s.x), atol=1e-5)


def test_four_channel_58b_accelerations(samples):
    c = read_uff(samples / "mpstd_set001_58b_4ch_accel.uff")
    assert [f.name for f in c.functions] == [f"MPS set1 Dof{k}" for k in range(1, 5)]
    assert [(f.rsp_node, f.rsp_dir) for f in c.functions] == [(1, 3), (2, 3), (3, 3), (1, 3)]
    for f in c.functions:
        assert f.data.size == 222400 and f.unit == "m/s2"
        assert f.x[1] == pytest.approx(3.125e-4)
        assert 0.01 < np.std(f.data) < 0.04  # low-level ambient vibration about an offset


def test_geometry_artemis_and_testlab_local_systems(samples):
    art = read_uff(samples / "artemis_geometry_15_82_2412.uff").geometry
    assert art.node_nums[:4].tolist() == [16, 17, 18, 19]
    np.testing.assert_allclose(art.xyz[:11, 0], [0, 1.53, 0, -1.53, 0, 1.53, 0, 1.53, 4.296, 5.616, 4.296])
    np.testing.assert_allclose(art.xyz[:11, 1], [0, 0, 3.84, 3.84, 0, 0, 3.84, 3.84, 0.382, 0.382, 1.102])
    np.testing.assert_allclose(art.xyz[:9, 2], [0, 0, 0, 0, 1.83, 1.83, 1.83, 1.83, 0.4])
    assert [len(n) for _, n in art.trace_lines] == [249, 75]

    tl = read_uff(samples / "testlab_geometry_151_164_18_15_82.uff").geometry
    assert len(tl.cs_rotation) == 36 and tl.node_nums.size == 36
    np.testing.assert_allclose(tl.cs_origin[1], [-2.4, -0.95, 0.0])
    # SYS1: x point (-3.4, -0.95, ~0), xz point (-3.4, -0.95, -1) -> x = -X, z = -Z, y = +Y
    R = tl.cs_rotation[1]
    np.testing.assert_allclose(R, np.diag([-1.0, 1.0, -1.0]), atol=1e-6)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(tl.direction(1, 3), [0, 0, -1], atol=1e-6)
    np.testing.assert_allclose(tl.direction(1, -1), [1, 0, 0], atol=1e-6)
    assert [(name, len(n)) for name, n in tl.trace_lines] == [("Massif", 9), ("Stator", 32), ("Dalle", 11)]
    assert tl.xyz[:, 0].min() == pytest.approx(-2.6) and tl.xyz[:, 1].max() == pytest.approx(8.4)


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("node_dataset", [15, 2411])
def test_export_reads_back_identically(tmp_path, samples, binary, node_dataset):
    rng = np.random.default_rng(3)
    geo = read_uff(samples / "testlab_geometry_151_164_18_15_82.uff").geometry
    funcs = [
        time_function("force", rng.standard_normal(300), 1e-3, "N", node=5, direction=-3),
        time_function("acc 1", rng.standard_normal(300), 1e-3, "m/s^2", node=1, direction=3),
        UffFunction("H 1/5", 4, np.arange(64) * 0.5, rng.standard_normal(64) + 1j * rng.standard_normal(64),
                    "(m/s^2)/N", "Hz", 1, 3, 5, -3),
    ]
    path = tmp_path / "out.uff"
    write_uff(path, functions=funcs, geometry=geo, binary=binary, node_dataset=node_dataset)
    # pyuff itself reads the same numbers
    raw = pyuff.UFF(str(path)).read_sets()
    fsets = [s for s in raw if s["type"] == 58]
    assert [s["id1"].strip() for s in fsets] == ["force", "acc 1", "H 1/5"]
    back = read_uff(path)
    assert back.dataset_types == [164, 18, node_dataset, 82, 82, 82, 58, 58, 58]
    tol = 0 if binary else 1e-10  # ASCII doubles carry 12 significant digits
    for a, b in zip(funcs, back.functions, strict=True):
        assert (a.name, a.func_type, a.unit, a.x_unit, a.rsp_node, a.rsp_dir, a.ref_node, a.ref_dir) == (
            b.name, b.func_type, b.unit, b.x_unit, b.rsp_node, b.rsp_dir, b.ref_node, b.ref_dir)
        np.testing.assert_allclose(b.data, a.data, rtol=tol, atol=0)
        np.testing.assert_allclose(b.x, a.x, rtol=1e-12)
    np.testing.assert_array_equal(back.geometry.node_nums, geo.node_nums)
    np.testing.assert_allclose(back.geometry.xyz, geo.xyz, atol=1e-9)
    assert back.geometry.trace_lines == geo.trace_lines
    for n, d in [(1, 3), (7, 1), (36, -2)]:
        np.testing.assert_allclose(back.geometry.direction(n, d), geo.direction(n, d), atol=1e-9)


def test_errors(tmp_path, samples):
    with pytest.raises(ConfigError, match="UFF file not found"):
        read_uff(tmp_path / "missing.uff")
    out = tmp_path / "x.uff"
    out.write_text("")
    with pytest.raises(ConfigError, match="refusing to overwrite"):
        write_uff(out, functions=[time_function("a", np.ones(4), 1.0, "V")])
    geo = UffGeometry(np.array([1]), np.zeros((1, 3)), np.array([0]))
    with pytest.raises(ConfigError, match="node 2 is not among"):
        geo.direction(2, 1)
    with pytest.raises(ConfigError, match="direction 4 at node 1"):
        geo.direction(1, 4)


# ----------------------------------------------------------------------------- projects <-> UFF

#: Dataset 15 writes coordinates as E13.5 (6 significant digits): 0.5 um on the rig's ~0.3 m
#: (dataset 2411 writes doubles).
XYZ_15 = 1e-6


@pytest.fixture(scope="module")
def thesis_record(tmp_path_factory):
    """A simulated thesis-rig record (nine accelerometers, force on channel 0) and its UFF export."""
    from odsuite.processing.acquisition import acquire
    from odsuite.contracts.daq import AcquisitionSettings
    from odsuite.contracts.plugins import registries
    from odsuite.store.project import create_project
    from odsuite_plugins.importers.uff_project import export_uff

    d = tmp_path_factory.mktemp("uff")
    with create_project(d / "p.h5") as p:
        acquire(p, registries().daq_backends.get("sim"), "e1", AcquisitionSettings(n_samples=1024), scenario="T3", seed=1)
    export_uff(d / "p.h5", d / "e1.uff")
    return d


def test_export_holds_physical_records_and_the_rigs_geometry(thesis_record):
    from odsuite.analysis.modal_project import physical
    from odsuite.store.project import open_project

    with open_project(thesis_record / "p.h5") as p:
        exp, rig = p.experiment("e1"), p.rig
        values = physical(exp)
    sets = pyuff.UFF(str(thesis_record / "e1.uff")).read_sets()  # pyuff alone, not our reader
    plated = [b for b in rig.bodies if b.plate is not None]
    sensed = [b for b in rig.bodies if sum(s.body == b.name for s in rig.sensors) > 1]
    assert [s["type"] for s in sets] == [164, 15] + [82] * (len(plated) + len(sensed)) + [58] * exp.n_channels
    c = read_uff(thesis_record / "e1.uff")
    geo = c.geometry
    for k, f in enumerate(c.functions):
        assert f.name == exp.channel_names[k] and f.unit == exp.systeminfo.channels[k].unit
        np.testing.assert_array_equal(f.data, values[:, k])  # binary doubles: lossless
        assert f.x[1] == pytest.approx(1 / exp.sampling_rate, rel=1e-12)
    outlines = {name: nodes for name, nodes in geo.trace_lines}
    for b in plated:  # the plate's top face (body z points down: z = corner z), one closed outline
        ids = outlines[f"{b.name} plate"]
        assert len(ids) == 5 and ids[0] == ids[-1]
        top = geo.xyz[np.searchsorted(geo.node_nums, ids[:4])]
        np.testing.assert_allclose(top[:, 2], b.plate.corner[2], atol=XYZ_15)
        np.testing.assert_allclose(top.min(axis=0)[:2], b.plate.corner[:2], atol=XYZ_15)
        np.testing.assert_allclose(top.max(axis=0)[:2] - top.min(axis=0)[:2], b.plate.size[:2], atol=2 * XYZ_15)
        # consecutive corners share an edge: one coordinate changes
        assert all(np.count_nonzero(~np.isclose(top[i], top[(i + 1) % 4])) == 1 for i in range(4))
    for s in rig.sensors:
        f = c.functions[s.channel]
        node = np.flatnonzero(geo.node_nums == f.rsp_node)[0]
        np.testing.assert_allclose(geo.xyz[node], s.position, atol=XYZ_15)
        np.testing.assert_allclose(geo.direction(f.rsp_node, f.rsp_dir), s.axis, atol=1e-12)
    force = c.functions[exp.excitation.force_channel]
    np.testing.assert_allclose(geo.xyz[np.flatnonzero(geo.node_nums == force.rsp_node)[0]], exp.excitation.point,
                               atol=XYZ_15)
    np.testing.assert_allclose(geo.direction(force.rsp_node, force.rsp_dir), exp.excitation.direction, atol=1e-12)


@pytest.mark.parametrize("binary", [True, False], ids=["58b", "ascii"])
def test_import_of_an_export_gives_the_experiment_back(thesis_record, tmp_path, binary):
    from odsuite.analysis.modal_project import physical
    from odsuite.store.project import create_project, open_project
    from odsuite_plugins.importers.uff_project import export_uff, import_uff

    src = thesis_record / "e1.uff"
    if not binary:
        src = export_uff(thesis_record / "p.h5", tmp_path / "e1-ascii.uff", binary=False, node_dataset=2411)
    create_project(tmp_path / "q.h5", rig=None).close()
    import_uff(tmp_path / "q.h5", src, "back")
    with open_project(thesis_record / "p.h5") as p, open_project(tmp_path / "q.h5") as q:
        a, b = p.experiment("e1"), q.experiment("back")
        assert b.channel_names == a.channel_names and b.sampling_rate == pytest.approx(a.sampling_rate, rel=1e-9)
        # ASCII 58 keeps 13 significant digits
        np.testing.assert_allclose(physical(b), physical(a), rtol=0 if binary else 1e-11, atol=0 if binary else 1e-9)
        assert b.excitation.force_channel == a.excitation.force_channel
        np.testing.assert_allclose(b.excitation.point, a.excitation.point, atol=XYZ_15 if binary else 1e-15)
        np.testing.assert_allclose(b.excitation.direction, a.excitation.direction, atol=1e-12)
        assert [c.sensor_type.name for c in b.systeminfo.channels] == [
            "LOADCELL" if k == a.excitation.force_channel else {"m/s^2": "ACCELEROMETER", "V": "VOLTAGE"}[c.unit]
            for k, c in enumerate(a.systeminfo.channels)]
        assert q.info()["experiments"]["back"]["clipped"] == []


def test_tilted_sensor_gets_a_local_displacement_system(tmp_path):
    from odsuite_plugins.importers.uff_project import _Nodes

    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    nodes = _Nodes()
    node, code = nodes.add(np.array([0.1, 0.2, 0.3]), axis)
    write_uff(tmp_path / "t.uff", geometry=nodes.geometry([]), binary=False)
    geo = read_uff(tmp_path / "t.uff").geometry
    np.testing.assert_allclose(geo.direction(node, code), axis, atol=1e-6)  # dataset 18 writes E13.5
    np.testing.assert_allclose(geo.xyz[0], [0.1, 0.2, 0.3])


def test_frfs_travel_with_the_record(real_data, tmp_path):
    from odsuite.analysis.modal_project import experiment_frf
    from odsuite_plugins.importers.columns import import_lvm
    from odsuite.store.project import create_project, open_project
    from odsuite_plugins.importers.uff_project import export_uff, import_uff

    create_project(tmp_path / "p.h5", rig=None).close()
    import_lvm(tmp_path / "p.h5", real_data / "ladisk_beam_impact" / "acceleration.lvm", "beam")
    frf, _ = experiment_frf(tmp_path / "p.h5", "beam")
    export_uff(tmp_path / "p.h5", tmp_path / "beam.uff")
    c = read_uff(tmp_path / "beam.uff")
    assert [f.func_type for f in c.functions].count(4) == len(frf.output_names) and c.geometry is None
    create_project(tmp_path / "q.h5", rig=None).close()
    import_uff(tmp_path / "q.h5", tmp_path / "beam.uff", "back")
    with open_project(tmp_path / "q.h5") as q:
        back = q.read_derived("back", "frf")
    # the dataset-58 header holds the line spacing as E13.5: 6 significant digits
    np.testing.assert_allclose(back["frequency"], frf.frequency, rtol=1e-5, atol=0)
    np.testing.assert_array_equal(back["H_real"] + 1j * back["H_imag"], frf.H)


def test_files_without_datasets_are_refused(tmp_path, thesis_record):
    from odsuite.store.project import create_project
    from odsuite_plugins.importers.uff_project import import_uff

    create_project(tmp_path / "q.h5", rig=None).close()
    before = (tmp_path / "q.h5").read_bytes()
    (tmp_path / "notes.uff").write_text("measured on Monday\nhammer on the corner\n")
    with pytest.raises(ConfigError, match=r"notes.uff: no UFF datasets found \(not a UFF file, or cut short\)$"):
        import_uff(tmp_path / "q.h5", tmp_path / "notes.uff", "x")
    (tmp_path / "cut.uff").write_bytes((thesis_record / "e1.uff").read_bytes()[:40])
    with pytest.raises(ConfigError, match="cut.uff: "):
        import_uff(tmp_path / "q.h5", tmp_path / "cut.uff", "x")
    assert (tmp_path / "q.h5").read_bytes() == before


def _imported_without_rig(tmp_path, unit: str):
    from odsuite.analysis.modal_project import physical
    from odsuite.store.project import create_project, open_project
    from odsuite_plugins.importers.uff_project import import_uff

    write_uff(tmp_path / "r.uff", functions=[time_function("acc", np.array([0.5, 1.5, 0.1, 0.0]), 1e-3, unit,
                                                           node=1, direction=3)], binary=False)
    create_project(tmp_path / "p.h5", rig=None).close()
    import_uff(tmp_path / "p.h5", tmp_path / "r.uff", "e")
    with open_project(tmp_path / "p.h5") as p:
        exp = p.experiment("e")
        return physical(exp)[:, 0].tolist(), exp.systeminfo.channels[0].sensor_type.name


@pytest.mark.parametrize("unit, si, sensor", [("g", [4.903325, 14.709975, 0.980665, 0.0], "ACCELEROMETER"),
                                              ("m/s^2", [0.5, 1.5, 0.1, 0.0], "ACCELEROMETER"),
                                              ("m/s²", [0.5, 1.5, 0.1, 0.0], "ACCELEROMETER"),
                                              ("N", [0.5, 1.5, 0.1, 0.0], "LOADCELL"),
                                              ("Pa", [0.5, 1.5, 0.1, 0.0], "PRESSURE"),
                                              ("m", [0.5, 1.5, 0.1, 0.0], "PROXIMITY"),
                                              ("m/s", [0.5, 1.5, 0.1, 0.0], "VELOCITY"),
                                              ("NONE", [0.5, 1.5, 0.1, 0.0], "NONE")])
def test_a_uff_record_without_a_rig_is_stored_in_si(tmp_path, unit, si, sensor):
    assert _imported_without_rig(tmp_path, unit) == (pytest.approx(si, rel=1e-15), sensor)


@pytest.mark.parametrize("unit", ["mg", "mm/s^2", "mN", "kN", "mV", "lbf", "in/s^2"])
def test_a_uff_record_without_a_rig_in_a_unit_of_another_scale_is_refused(tmp_path, unit):
    # stored as volts at scale 1 (no sensor): 1.5 mg read as 1.5 instead of 0.0147 m/s^2
    with pytest.raises(ConfigError) as info:
        _imported_without_rig(tmp_path, unit)
    assert str(info.value) == (f"{tmp_path / 'r.uff'}: dataset 2 (58 'acc') record 9 field 6 (ordinate units label): "
                               f"{unit!r} is not one of m/s^2, g, N, V, Pa, m, m/s or NONE")
    from odsuite.store.project import open_project

    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []


def _in_units_of(path, functions, code: int, description: str, length: float, force: float):
    """``functions`` written by write_uff, its SI 164 set replaced by one of another unit system."""
    write_uff(path.with_suffix(".si"), functions=functions, binary=False)
    sets = pyuff.UFF(str(path.with_suffix(".si"))).read_sets()
    assert sets[0]["type"] == 164
    sets[0] = pyuff.prepare_164(units_code=code, units_description=description, temp_mode=2, length=length,
                                force=force, temp=1.0, temp_offset=273.15, return_full_dict=True)
    path.write_bytes(b"")
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


@pytest.mark.parametrize("unit", ["m/s^2", "N", "g", "Pa", "m"])
def test_records_of_a_file_in_other_units_than_si_are_refused(tmp_path, unit):
    """164 says the values are in file units (SI times its factors: mm and mN here); they were read
    as SI by their labels, 1000 times off. Refused, as a label of another scale is; the project is
    left as it was."""
    from odsuite.store.project import create_project, open_project
    from odsuite_plugins.importers.uff_project import import_uff

    data = np.array([0.5, 1.5, 0.1, 0.0])
    uff = _in_units_of(tmp_path / "mm.uff", [time_function("acc", data, 1e-3, unit, node=1, direction=3)],
                       5, "mm (milli newton)", 1000.0, 1000.0)
    create_project(tmp_path / "p.h5", rig=None).close()
    before = (tmp_path / "p.h5").read_bytes()
    with pytest.raises(ConfigError) as info:
        import_uff(tmp_path / "p.h5", uff, "e")
    assert str(info.value) == (f"{uff}: dataset 164 gives the file's units as 'mm (milli newton)' (length factor "
                               f"1000, force factor 1000 per SI unit): record 'acc' ({unit}) would be read as SI; "
                               "odsuite imports records in SI units only")
    assert (tmp_path / "p.h5").read_bytes() == before
    with open_project(tmp_path / "p.h5") as p:
        assert p.experiment_names() == []


def test_in_other_units_only_volts_and_unitless_records_are_imported(tmp_path):
    """Volts and UFF's NONE (exponents 0) mean the same in any unit system; an FRF is a record too,
    and a 164 of factors 1 (SI, whatever its code) changes nothing."""
    from odsuite.store.project import create_project
    from odsuite_plugins.importers.uff_project import import_uff

    data = np.array([0.5, 1.5, 0.1, 0.0])
    create_project(tmp_path / "p.h5", rig=None).close()
    uff = _in_units_of(tmp_path / "v.uff", [time_function("u", data, 1e-3, "V"), time_function("w", data, 1e-3, "")],
                       2, "BG: Foot (pound f)", 3.28083989501312334, 2.24808943099710480e-01)
    import_uff(tmp_path / "p.h5", uff, "volts")
    frf = UffFunction("H", 4, np.array([0.0, 1.0, 2.0]), np.array([1, 2j, 3]), "m/s^2/N", "Hz", 1, 3, 1, 3)
    uff = _in_units_of(tmp_path / "h.uff", [frf], 8, "GM: mm (kilogram f)", 1000.0, 1 / 9.80665)
    with pytest.raises(ConfigError, match=r"factor 1000, force factor 0.101972 per SI unit\): record 'H' \(m/s\^2/N\)"):
        import_uff(tmp_path / "p.h5", uff, "h")
    uff = _in_units_of(tmp_path / "si.uff", [time_function("acc", data, 1e-3, "m/s^2")], 9, "US: user", 1.0, 1.0)
    import_uff(tmp_path / "p.h5", uff, "si")


def _pyuff_time_record(name: str, data: np.ndarray, dt: float, spec: int, exps: tuple[int, int], label: str,
                       node: int) -> dict:
    """A dataset 58 time record written by pyuff itself (record 9: specific data type, length and
    force exponents, units label), not by odsuite's write_uff."""
    return pyuff.prepare_58(
        binary=0, id1=name, id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1, ver_num=0, load_case_id=0,
        rsp_ent_name="NONE", rsp_node=node, rsp_dir=3, ref_ent_name="NONE", ref_node=0, ref_dir=0, ord_data_type=4,
        num_pts=data.size, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=dt, z_axis_value=0.0,
        abscissa_spec_data_type=17, abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
        abscissa_axis_units_lab="s", ordinate_spec_data_type=spec, ordinate_len_unit_exp=exps[0],
        ordinate_force_unit_exp=exps[1], ordinate_temp_unit_exp=0, ordinate_axis_units_lab=label,
        orddenom_spec_data_type=0, orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0,
        orddenom_axis_units_lab="NONE", z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0,
        z_axis_temp_unit_exp=0, z_axis_axis_units_lab="NONE", data=data, x=np.arange(data.size) * dt,
        return_full_dict=True)


def _three_quantities(path, pressure_label: str = "Pa") -> dict[str, np.ndarray]:
    """An acceleration (m/s^2), a force (N) and a microphone's pressure (Pa) in an SI file."""
    t = np.arange(512) / 2048.0
    arrays = {"acc": 3.25 * np.sin(2 * np.pi * 40 * t), "force": 120.0 * np.exp(-((t - 0.01) / 1e-3) ** 2),
              "mic": 0.8125 * np.sin(2 * np.pi * 100 * t + 0.3)}
    sets = [pyuff.prepare_164(units_code=1, units_description="SI", temp_mode=2, length=1.0, force=1.0, temp=1.0,
                              temp_offset=273.15, return_full_dict=True),
            _pyuff_time_record("acc", arrays["acc"], t[1], 12, (1, 0), "m/s^2", 1),
            _pyuff_time_record("force", arrays["force"], t[1], 13, (0, 1), "N", 2),
            _pyuff_time_record("mic", arrays["mic"], t[1], 15, (-2, 1), pressure_label, 3)]
    path.write_bytes(b"")
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return arrays


def test_each_record_keeps_its_quantity_and_si_unit(tmp_path, capsys):
    """A microphone's record in Pa was stored as a channel without a sensor, which odsuite reports
    in volts; each record keeps its quantity and SI unit (checked against the arrays pyuff wrote)."""
    import json

    from odsuite.analysis.modal_project import physical
    from odsuite.cli import main
    from odsuite.store.project import open_project

    arrays = _three_quantities(tmp_path / "r.uff")
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    assert main(["import", str(p), str(tmp_path / "r.uff"), "--name", "e"]) == 0
    capsys.readouterr()
    assert main(["info", str(p), "--json"]) == 0
    peak = json.loads(capsys.readouterr().out)["experiments"]["e"]["peak"]
    units = {"acc": "m/s^2", "force": "N", "mic": "Pa"}
    assert {n: u for n, (_, u) in peak.items()} == units
    for n, a in arrays.items():
        assert peak[n][0] == pytest.approx(np.abs(a).max(), rel=1e-10)
    with open_project(p) as project:
        exp = project.experiment("e")
        assert [(c.quantity, c.unit) for c in exp.systeminfo.channels] == [
            ("acceleration", "m/s^2"), ("force", "N"), ("pressure", "Pa")]
        np.testing.assert_allclose(physical(exp), np.column_stack(list(arrays.values())), rtol=1e-11, atol=1e-13)


def test_a_record_in_a_unit_odsuite_cannot_use_is_refused_in_one_line(tmp_path, capsys):
    from odsuite.cli import main

    _three_quantities(tmp_path / "r.uff", pressure_label="dB")
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    before = p.read_bytes()
    capsys.readouterr()
    assert main(["import", str(p), str(tmp_path / "r.uff"), "--name", "e"]) == 1
    err = capsys.readouterr().err
    assert err == (f"error: {tmp_path / 'r.uff'}: dataset 4 (58 'mic') record 9 field 6 (ordinate units label): "
                   "'dB' is not one of m/s^2, g, N, V, Pa, m, m/s or NONE\n")
    assert p.read_bytes() == before


def test_a_pressure_record_is_not_taken_as_the_force(tmp_path, capsys):
    # a record without a sensor could be named the force: the microphone's Pa was stored as N
    from odsuite.cli import main

    _three_quantities(tmp_path / "r.uff")
    p = tmp_path / "p.h5"
    assert main(["new", str(p), "--rig", "none"]) == 0
    capsys.readouterr()
    assert main(["import", str(p), str(tmp_path / "r.uff"), "--name", "e", "--force-channel", "mic"]) == 1
    assert capsys.readouterr().err == (f"error: {tmp_path / 'r.uff'}: --force-channel 'mic' is in 'Pa', a response, "
                                       "not a force\n")
