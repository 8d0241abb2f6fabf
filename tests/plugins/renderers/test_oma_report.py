"""`odsuite report` on projects without a rig: operating records of a structure, imported as a lab
would (CSV records and a geometry table, through the command line). A 3-storey shear building
simulated under white floor forces (its modes from scipy.linalg.eigh) measured in two setups that
share the top floor's sensors; the Palisaden building's real record against pyOMA2's published
modes; a record without geometry."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from odsuite.cli import main

FS = 100.0
MASS = np.array([2000.0, 2000.0, 1500.0])  # kg per floor
STIFF = np.array([3.0e6, 2.5e6, 2.0e6])  # N/m per storey, ground up
ZETA = 0.02
PLAN = (4.0, 3.0)  # m: each floor's corners (0, 0) .. (4, 3); storeys 3 m
# channel -> (floor, corner (x, y)); every sensor measures along +x
SENSORS = {"f1a": (1, (0, 0)), "f1b": (1, (4, 3)), "f2a": (2, (0, 0)), "f2b": (2, (4, 3)),
           "f3a": (3, (0, 0)), "f3b": (3, (4, 3))}
# two setups sharing the top floor's sensors; the second at three times the excitation
SETUPS = {"setup1": (["f3a", "f3b", "f1a", "f1b"], 1.0, 1), "setup2": (["f3a", "f3b", "f2a", "f2b"], 3.0, 2)}


def exact_modes() -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and mass-normalised shapes (floors x modes) of the shear chain."""
    k = STIFF
    K = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    w2, phi = scipy.linalg.eigh(K, np.diag(MASS))
    return np.sqrt(w2) / (2 * np.pi), phi


def floor_accelerations(seconds: float, seed: int, level: float) -> np.ndarray:
    """Floor accelerations (samples x floors, m/s²) under independent white forces at each floor,
    modal damping ZETA, exact zero-order-hold discretisation, 1 % sensor noise."""
    f, phi = exact_modes()
    w = 2 * np.pi * f
    M, n = np.diag(MASS), MASS.size
    K = np.linalg.inv(phi.T) @ np.diag(w ** 2) @ np.linalg.inv(phi)
    C = np.linalg.inv(phi.T) @ np.diag(2 * ZETA * w) @ np.linalg.inv(phi)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]])
    B = np.vstack([np.zeros((n, n)), Minv])
    Cd, D = np.hstack([-Minv @ K, -Minv @ C]), Minv
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, Cd, D), 1 / FS)
    rng = np.random.default_rng(seed)
    u = level * 1e3 * rng.standard_normal((int(seconds * FS), n))
    x = np.zeros(2 * n)
    y = np.empty((u.shape[0], n))
    for i in range(u.shape[0]):
        y[i] = Cd @ x + D @ u[i]
        x = Ad @ x + Bd @ u[i]
    return y + 0.01 * y.std(axis=0) * rng.standard_normal(y.shape)


def geometry_csv() -> str:
    """The building as a geometry table: four corners per level, columns and floor outlines, the
    ground fixed, each floor a rigid group, the sensors along +x."""
    lx, ly = PLAN
    rows, ids = ["units,m"], {}
    for level in range(4):
        for c, (x, y) in enumerate(((0, 0), (lx, 0), (lx, ly), (0, ly))):
            ids[level, (x, y)] = 10 * level + c + 1
            rows.append(f"node,{10 * level + c + 1},{x},{y},{3.0 * level}")
        ring = [10 * level + c + 1 for c in range(4)]
        rows += [f"line,{a},{b}" for a, b in zip(ring, ring[1:] + ring[:1])]
        if level:
            rows += [f"line,{a - 10},{a}" for a in ring]
            rows.append(f"rigid,floor{level}," + ",".join(map(str, ring)))
    rows.append("fixed,1,2,3,4")
    rows += [f"sensor,{ch},{ids[floor, corner]},+x" for ch, (floor, corner) in SENSORS.items()]
    return "\n".join(rows) + "\n"


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def table(page: str, ident: str) -> list[list[str]]:
    """The body rows of the table with this id, cells as text."""
    body = re.search(rf'<table id="{re.escape(ident)}".*?<tbody>(.*?)</tbody>', page, re.S)
    assert body, f"no table {ident!r} in the page"
    return [[re.sub(r"<[^>]+>", "", c) for c in re.findall(r"<td>(.*?)</td>", r, re.S)]
            for r in re.findall(r"<tr>(.*?)</tr>", body.group(1), re.S)]


def view_data(page: str) -> dict | None:
    m = re.search(r'<script type="application/json" class="m-data">(.*?)</script>', page, re.S)
    return None if m is None else json.loads(m.group(1).replace("<\\/", "</"))


def view_frequencies(data: dict) -> np.ndarray:
    return np.array([float(re.search(r"([0-9.]+) Hz", m["label"]).group(1)) for m in data["modes"]])


@pytest.fixture(scope="module")
def shear_survey(tmp_path_factory):
    """The two setups written as CSV files (a time column, units in the header) and the geometry as
    a CSV table, imported into a rig-less project through the command line; the report written."""

    folder = tmp_path_factory.mktemp("shear")
    project = folder / "building.h5"
    assert main(["new", str(project), "--rig", "none"]) == 0
    floor_of = {ch: floor for ch, (floor, _) in SENSORS.items()}
    for name, (channels, level, seed) in SETUPS.items():
        y = floor_accelerations(600.0, seed, level)
        t = np.arange(y.shape[0]) / FS
        cols = np.column_stack([t] + [y[:, floor_of[c] - 1] for c in channels])
        header = "time," + ",".join(f"{c} [m/s^2]" for c in channels)
        np.savetxt(folder / f"{name}.csv", cols, delimiter=",", header=header, comments="", fmt="%.9g")
        assert main(["import", str(project), str(folder / f"{name}.csv"), "--name", name]) == 0
    (folder / "building.csv").write_text(geometry_csv())
    assert main(["import", str(project), str(folder / "building.csv"), "--name", "geometry", "--format", "geometry"]) == 0
    assert main(["report", str(project), "-o", str(folder / "report.html")]) == 0
    return project, (folder / "report.html").read_text()


def test_shear_building_report_has_its_known_modes(shear_survey):
    """Each setup's table and the merged table hold the three modes of eigh within 1 %, EFDD beside
    SSI-cov (MAC >= 0.95), and the 3-D view animates the merged modes, whose x motion at the
    sensors' nodes has MAC >= 0.95 with the exact shapes."""
    from odsuite.analysis.modal import mac

    _, page = shear_survey
    f0, phi = exact_modes()
    for name in SETUPS:
        rows = table(page, f"modes-{name}")
        f = np.array([float(r[1]) for r in rows])
        pick = [int(np.argmin(np.abs(f - v))) for v in f0]
        np.testing.assert_allclose(f[pick], f0, rtol=0.01)
        np.testing.assert_allclose([float(rows[k][3]) for k in pick], 100 * ZETA, rtol=0.35)
        assert min(float(rows[k][11]) for k in pick) >= 0.95  # MAC SSI-EFDD
    merged = table(page, "merged-modes")
    fm = np.array([float(r[1]) for r in merged])
    np.testing.assert_allclose(np.sort(fm)[:3], f0, rtol=0.01)
    data = view_data(page)
    assert data is not None and "merged OMA" in data["modes"][0]["label"]
    fv = view_frequencies(data)
    np.testing.assert_allclose(fv, fm, rtol=1e-3)
    nodes = np.array(data["nodes"]).reshape(-1, 3) / 1e3
    # node of sensor "a" on each floor: the corner (0, 0) at z = 3, 6, 9 m
    at = [int(np.argmin(np.linalg.norm(nodes - [0, 0, 3.0 * k], axis=1))) for k in (1, 2, 3)]
    pick = [int(np.argmin(np.abs(fv - v))) for v in f0]
    shapes = np.array([[data["modes"][k]["re"][3 * j] + 1j * data["modes"][k]["im"][3 * j] for j in at]
                       for k in pick]).T
    assert np.diag(mac(shapes, phi)).min() >= 0.95
    assert "no rig, so they are left out" in page


def test_rigless_record_without_geometry(tmp_path, capsys):
    """One record, no geometry: the page has the modes and says in one sentence why there is no
    3-D view."""
    y = floor_accelerations(300.0, 5, 1.0)
    header = "time,x1 [m/s^2],x2 [m/s^2],x3 [m/s^2]"
    np.savetxt(tmp_path / "r.csv", np.column_stack([np.arange(y.shape[0]) / FS, y]), delimiter=",", header=header,
               comments="", fmt="%.9g")
    project = tmp_path / "p.h5"
    assert run(capsys, "new", project, "--rig", "none")[0] == 0
    assert run(capsys, "import", project, tmp_path / "r.csv", "--name", "ambient")[0] == 0
    code, out, err = run(capsys, "report", project, "-o", tmp_path / "r.html", "--json")
    assert code == 0, err
    assert json.loads(out)["summary"].endswith("output-only: no model")
    page = (tmp_path / "r.html").read_text()
    f = np.array([float(r[1]) for r in table(page, "modes-ambient")])
    f0, _ = exact_modes()
    np.testing.assert_allclose([f[np.argmin(np.abs(f - v))] for v in f0], f0, rtol=0.01)
    assert view_data(page) is None and "No 3-D view: the project has no geometry" in page
    assert "One record: no setups to merge." in page


@pytest.mark.slow
def test_palisaden_report(tmp_path, capsys, real_data):
    """The building's record and geometry imported as docs/geometry.md shows: the report's modes
    table and its 3-D view hold pyOMA2's published SSI-cov modes within 0.5 %, and they are the
    modes `odsuite modes --output-only` prints (one default, so the two entry points agree)."""
    base = real_data / "palisaden_building"
    np.save(tmp_path / "pali.npy", np.load(base / "Palisaden_dataset.npy"))
    (tmp_path / "pali.toml").write_text('sampling_rate = 100.0\nunits = "m/s^2"\n')
    project = tmp_path / "p.h5"
    example = Path(__file__).resolve().parents[3] / "examples" / "geometry" / "palisaden.toml"
    assert run(capsys, "new", project, "--rig", "none")[0] == 0
    for file, name in ((tmp_path / "pali.npy", "ambient"), (example, "geometry")):
        assert run(capsys, "import", project, file, "--name", name)[0] == 0
    code, _, err = run(capsys, "report", project, "-o", tmp_path / "r.html")
    assert code == 0, err
    page = (tmp_path / "r.html").read_text()
    published = json.loads((base / "pyoma2_reference.json").read_text())["published_hz"]["SSIcov"]
    f = np.array([float(r[1]) for r in table(page, "modes-ambient")])
    fv = view_frequencies(view_data(page))
    for got in (f, fv):
        np.testing.assert_allclose([got[np.argmin(np.abs(got - p))] for p in published], published, rtol=0.005)
    code, out, _ = run(capsys, "modes", project, "--experiment", "ambient", "--output-only", "--json")
    assert code == 0
    np.testing.assert_allclose(f, [m["frequency_hz"] for m in json.loads(out)["modes"]], rtol=1e-4)


def test_rigless_hammer_records_report_their_frfs_and_modes(tmp_path, capsys, real_data):
    """The LADISK beam's impact record on a project without a rig: the page shows its FRFs, its
    stabilisation diagram and its modes, the published four within 0.5 % in frequency and 30 % in
    damping (the data's README), the same as `odsuite modes` prints. The report refused such a
    project ("no operating record to analyse ... `odsuite import` adds a record")."""
    published_hz = np.array([695.0, 1897.6, 2777.3, 3671.2])
    published_zeta = np.array([0.0047, 0.0031, 0.0024, 0.0020])
    project = tmp_path / "beam.h5"
    assert run(capsys, "new", project, "--rig", "none")[0] == 0
    assert run(capsys, "import", project, real_data / "ladisk_beam_impact" / "acceleration.lvm", "--name", "hit")[0] == 0
    code, out, err = run(capsys, "report", project, "-o", tmp_path / "r.html", "--json")
    assert code == 0, err
    assert json.loads(out)["summary"].endswith("no rig: no model")
    page = (tmp_path / "r.html").read_text()
    rows = table(page, "ema-modes-hit")
    f, zeta = np.array([float(r[1]) for r in rows]), np.array([float(r[2]) / 100 for r in rows])
    np.testing.assert_allclose(f, published_hz, rtol=0.005)
    np.testing.assert_allclose(zeta, published_zeta, rtol=0.30)
    code, out, _ = run(capsys, "modes", project, "--experiment", "hit", "--json")
    assert code == 0
    printed = json.loads(out)["modes"]
    np.testing.assert_allclose(f, [m["frequency_hz"] for m in printed], atol=0.005)
    assert page.count("<img") >= 2 and "output-only" not in page.split("<h2>Summary</h2>")[1].split("</section>")[0]
