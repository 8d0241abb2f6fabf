"""A structure's geometry: the rule by which unmeasured nodes follow measured ones (closed forms),
TOML and CSV tables, UFF 15/82 both ways and mode shapes as UFF 55 (read back by pyuff), bad tables
in one line, and the Palisaden building's geometry against the files published with its record."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from odsuite.domain.errors import OdsuiteError
from odsuite.domain.geometry import IDW_POWER, Geometry, GeometrySensor, project_geometry
from odsuite.store.project import create_project, open_project
from odsuite_plugins.importers.geometry_files import read_geometry, read_geometry_uff, write_geometry_uff

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "geometry" / "palisaden.toml"
RNG = np.random.default_rng(3)


def _floor() -> Geometry:
    """A 4 x 2 m floor at z = 3 m (corners 1-4) with three measured points (5-7), x and y sensors
    on each (one of them oblique), a ground corner 8 fixed and a node 9 below a corner, free."""
    xyz = np.array([[0, 0, 3], [4, 0, 3], [4, 2, 3], [0, 2, 3], [0.5, 0.5, 3], [3.5, 0.5, 3], [2, 1.8, 3],
                    [0, 0, 0], [4, 2, 1]], float)
    s = 2 ** -0.5
    sensors = (GeometrySensor("a", 5, (1, 0, 0)), GeometrySensor("b", 5, (0, 1, 0)),
               GeometrySensor("c", 6, (s, s, 0)), GeometrySensor("d", 6, (0, -1, 0)),
               GeometrySensor("e", 7, (-1, 0, 0)), GeometrySensor("f", 7, (0, 1, 0)))
    return Geometry("floor", np.arange(1, 10), xyz, [[1, 2], [2, 3], [3, 4], [4, 1], [1, 8], [3, 9]],
                    ((1, 2, 3, 4),), sensors, fixed=(8,), rigid=(("floor", (1, 2, 3, 4, 5, 6, 7)),))


def test_a_rigid_floor_moves_as_the_rigid_motion_its_sensors_read():
    g = _floor()
    t, theta = np.array([1e-3, -2e-3, 0.0]), np.array([0.0, 0.0, 4e-4])  # in-plane: what x, y sensors see
    centre = g.xyz[:7].mean(axis=0)
    truth = t + np.cross(theta, g.xyz - centre)
    readings = {s.channel: float(np.dot(s.direction, truth[g.index(s.node)])) for s in g.sensors}
    u = g.node_motion(readings)
    assert np.allclose(u[:7, :2], truth[:7, :2], rtol=0, atol=1e-15)
    # the floor's vertical motion is seen by no sensor: it follows the fixed ground (zero) by IDW
    assert np.allclose(u[:7, 2], 0.0, atol=1e-18)
    assert np.allclose(u[7], 0.0)  # fixed
    # node 9 (z = 1 m under corner 3) by inverse-distance weights of every node knowing its axis
    known = np.arange(8)
    d = np.linalg.norm(g.xyz[known] - g.xyz[8], axis=1)
    w = d ** -IDW_POWER
    assert np.allclose(u[8, :2], (w / w.sum()) @ u[known, :2], rtol=1e-12)


def test_a_node_with_sensors_outside_a_group_solves_its_own_readings():
    xyz = np.array([[0, 0, 0], [1, 0, 0], [3, 0, 0]], float)
    n = np.array([1.0, 2.0, 0.0]) / np.sqrt(5)
    g = Geometry("beam", np.array([1, 2, 3]), xyz, [[1, 2], [2, 3]],
                 sensors=(GeometrySensor("x", 2, (1, 0, 0)), GeometrySensor("n", 2, tuple(n))), fixed=(1,))
    truth = np.array([0.3, -0.7, 0.0])
    u = g.node_motion({"x": truth[0], "n": float(n @ truth)})
    assert np.allclose(u[1, :2], truth[:2])
    # z is measured nowhere but at the fixed node: zero; node 3 follows nodes 1 (d 3 m) and 2 (d 2 m)
    w = np.array([3.0, 2.0]) ** -IDW_POWER
    assert np.allclose(u[2, :2], (w[1] / w.sum()) * truth[:2])
    assert u[2, 2] == 0.0


def test_toml_and_csv_tables_give_the_same_geometry(tmp_path):
    (tmp_path / "g.toml").write_text(
        'units = "mm"\nnodes = [[1, 0, 0, 0], [2, 1000, 0, 0], [3, 1000, 500, 0]]\nlines = [[1, 2], [2, 3]]\n'
        'faces = [[1, 2, 3]]\nfixed = [1]\nsensors = [["acc", 3, "-z"], ["acc2", 2, [0, 3, 4]]]\n'
        '[[rigid]]\nname = "tip"\nnodes = [2, 3]\n')
    (tmp_path / "g.csv").write_text(
        "# the same in a table\nunits,mm\nnode,1,0,0,0\nnode,2,1000,0,0\nnode,3,1000,500,0\nline,1,2\nline,2,3\n"
        "face,1,2,3\nfixed,1\nsensor,acc,3,-z\nsensor,acc2,2,0 3 4\nrigid,tip,2,3\n")
    a, b = read_geometry(tmp_path / "g.toml", "g"), read_geometry(tmp_path / "g.csv", "g")
    assert np.array_equal(a.xyz, b.xyz) and np.allclose(a.xyz[2], [1.0, 0.5, 0.0])
    assert np.array_equal(a.lines, b.lines) and a.faces == b.faces == ((1, 2, 3),)
    assert a.sensors == b.sensors and a.sensors[1].direction == pytest.approx((0.0, 0.6, 0.8))
    assert a.fixed == b.fixed and a.rigid == b.rigid


@pytest.mark.parametrize("text, words", [
    ("node,1,0,0,0\nline,1,2\n", ["g.csv", "line", "node 2"]),
    ("node,1,0,0\n", ["g.csv", "node '1'", "2 coordinates"]),
    ("node,1,0,0,x\n", ["g.csv", "node 1 coordinate", "'x'"]),
    ("node,1,0,0,0\nnode,1,1,0,0\n", ["g.csv", "node 1 is given twice"]),
    ("node,1,0,0,0\nsensor,a,1,up\n", ["g.csv", "line 2", "sensor 'a'", "'up'"]),
    ("node,1,0,0,0\nfixed,1\nsensor,a,1,+x\n", ["g.csv", "node 1 is fixed"]),
    ("units,furlong\nnode,1,0,0,0\n", ["g.csv", "units", "'furlong'"]),
    ("pont,1,0,0,0\n", ["g.csv", "line 1", "'pont'"]),
    ("", ["g.csv", "nodes", "none"]),
])
def test_a_bad_table_is_one_line(tmp_path, text, words):
    (tmp_path / "g.csv").write_text(text)
    with pytest.raises(OdsuiteError) as err:
        read_geometry(tmp_path / "g.csv", "g")
    assert "\n" not in str(err.value)
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_geometry_round_trips_through_uff_15_82_and_modes_are_uff_55_for_pyuff(tmp_path):
    import pyuff

    g = _floor()
    shapes = [(1.5, 0.02, RNG.normal(size=(9, 3)) + 1j * RNG.normal(size=(9, 3))),
              (4.25, 0.013, RNG.normal(size=(9, 3)) + 0j)]
    write_geometry_uff(tmp_path / "g.uff", g, shapes)
    sets = pyuff.UFF(str(tmp_path / "g.uff")).read_sets()
    nodes = next(s for s in sets if s["type"] == 15)
    assert np.array_equal(nodes["node_nums"], g.node_ids)
    assert np.allclose(np.column_stack([nodes["x"], nodes["y"], nodes["z"]]), g.xyz, rtol=1e-6, atol=0)
    modes = [s for s in sets if s["type"] == 55]
    assert len(modes) == 2
    for s, (f, zeta, u) in zip(modes, shapes):
        assert np.array_equal(s["node_nums"], g.node_ids)
        got = np.column_stack([s["r1"], s["r2"], s["r3"]])
        assert np.allclose(got, u, rtol=1e-5, atol=1e-6 * np.abs(u).max())
        lam = s["eig"]
        assert abs(lam) / (2 * np.pi) == pytest.approx(f, rel=1e-5)
        assert -lam.real / abs(lam) == pytest.approx(zeta, rel=1e-4)
    back = read_geometry_uff(tmp_path / "g.uff", "back")
    assert np.array_equal(back.node_ids, g.node_ids) and np.allclose(back.xyz, g.xyz, rtol=1e-6)
    assert sorted(map(tuple, back.lines.tolist())) == sorted(map(tuple, g.lines.tolist()))
    # and the geometry written by pyuff alone reads back the same way
    pyuff.UFF(str(tmp_path / "p.uff")).write_sets(
        [pyuff.prepare_15(node_nums=g.node_ids, def_cs=[0] * 9, disp_cs=[0] * 9, color=[1] * 9,
                          x=g.xyz[:, 0], y=g.xyz[:, 1], z=g.xyz[:, 2], return_full_dict=True),
         pyuff.prepare_82(trace_num=1, n_nodes=3, color=1, id="t", nodes=np.array([1, 2, 3]), return_full_dict=True)],
        mode="add")
    other = read_geometry_uff(tmp_path / "p.uff", "p")
    assert np.allclose(other.xyz, g.xyz, rtol=1e-6) and sorted(map(tuple, other.lines.tolist())) == [(1, 2), (2, 3)]


def test_a_geometry_is_stored_in_the_project_through_the_importer(tmp_path, registries):
    create_project(tmp_path / "p.h5", rig=None).close()
    imp = registries.importers.get("geometry")
    res = imp.import_file(tmp_path / "p.h5", EXAMPLE, "geometry")
    assert "42 nodes" in res.summary and "6 sensors" in res.summary
    with open_project(tmp_path / "p.h5") as p:
        g = project_geometry(p)
    ref = read_geometry(EXAMPLE, "geometry")
    assert np.array_equal(g.node_ids, ref.node_ids) and np.array_equal(g.xyz, ref.xyz)
    assert np.array_equal(g.lines, ref.lines) and g.faces == ref.faces and g.fixed == ref.fixed
    assert g.sensors == ref.sensors and g.rigid == ref.rigid
    assert g.channels == [f"ch{k}" for k in range(1, 7)] and g.rigid[0][0] == "top floor"


def _columns(path: Path) -> np.ndarray:
    return np.loadtxt(path, skiprows=1, usecols=(1, 2, 3))


def test_the_palisaden_geometry_is_the_published_one(real_data):
    base = real_data / "palisaden_building"
    geo = base / "geometry"
    g = read_geometry(EXAMPLE, "palisaden")
    bg = np.loadtxt(geo / "BG_nodes.txt")
    assert np.array_equal(g.xyz[[g.index(n) for n in range(1, 9)]], bg)
    names = np.loadtxt(geo / "sens_coord.txt", skiprows=1, usecols=0, dtype=str)
    where = dict(zip(names, _columns(geo / "sens_coord.txt")))
    dirs = dict(zip(names, np.loadtxt(geo / "sens_dir.txt")))
    for s in g.sensors:
        assert np.array_equal(g.xyz[g.index(s.node)], where[s.channel])
        assert np.array_equal(s.direction, dirs[s.channel])
    # pyOMA2's shapes on the geometry: mode 1 sways the top along y, mode 3 twists it about z
    ref = json.loads((base / "pyoma2_reference.json").read_text())["modes"]["SSIcov"]["shape"]
    phi = (np.array(ref["re"]) + 1j * np.array(ref["im"])).T  # channels x modes
    top = [g.index(n) for n in (5, 6, 7, 8)]
    u1 = g.node_motion({f"ch{k + 1}": phi[k, 0] for k in range(6)}).real[top]
    assert np.all(np.abs(u1[:, 1]) > 5 * np.abs(u1[:, 0]))
    assert np.all(np.sign(u1[:, 1]) == np.sign(u1[0, 1]))  # every corner the same way: a sway, not a twist
    u3 = g.node_motion({f"ch{k + 1}": phi[k, 2] for k in range(6)}).real[top]
    centre = g.xyz[top].mean(axis=0)
    spin = np.cross(g.xyz[top] - centre, u3)[:, 2]
    assert np.all(np.sign(spin) == np.sign(spin[0]))  # every corner turns the same way
