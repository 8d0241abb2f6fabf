"""Universal File Format (UFF/UNV) through pyuff: functions (58/58b: time records, FRFs), nodes
(15, 2411), coordinate systems (18) and trace lines (82).

Node coordinates are returned in the global frame (a node defined in a local coordinate system is
transformed); each node's displacement coordinate system gives its measurement directions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from odsuite.core import uff_checks
from odsuite.core.errors import ConfigError

#: dataset 58 function types used here
FUNC_TIME = 1
FUNC_FRF = 4
#: dataset 58 ordinate data types: real double, complex double
ORD_REAL_DOUBLE = 4
ORD_COMPLEX_DOUBLE = 6


# dataset-58 header fields pyuff needs written out (0 or "NONE": not specified)
_58_ZERO_FIELDS = (
    "ver_num", "load_case_id", "ordinate_spec_data_type", "ordinate_len_unit_exp",
    "ordinate_force_unit_exp", "ordinate_temp_unit_exp", "orddenom_spec_data_type",
    "orddenom_len_unit_exp", "orddenom_force_unit_exp", "orddenom_temp_unit_exp",
    "z_axis_spec_data_type", "z_axis_len_unit_exp", "z_axis_force_unit_exp", "z_axis_temp_unit_exp",
    "abscissa_len_unit_exp", "abscissa_force_unit_exp", "abscissa_temp_unit_exp",
)
_58_LABEL_FIELDS = (
    "id3", "id4", "id5", "rsp_ent_name", "ref_ent_name", "orddenom_axis_units_lab", "z_axis_axis_units_lab",
)


@dataclass(frozen=True)
class UffFunction:
    """One dataset 58: ordinate ``data`` over abscissa ``x`` (s for time data, Hz for FRFs)."""

    name: str
    func_type: int
    x: np.ndarray
    data: np.ndarray
    unit: str
    x_unit: str
    rsp_node: int = 0
    rsp_dir: int = 0
    ref_node: int = 0
    ref_dir: int = 0
    description: str = ""

    @property
    def is_time(self) -> bool:
        return self.func_type == FUNC_TIME


@dataclass(frozen=True)
class UffGeometry:
    """Nodes (global coordinates), their displacement coordinate systems, the coordinate systems
    (rotation matrices local -> global and origins) and trace lines (0 = pen up)."""

    node_nums: np.ndarray
    xyz: np.ndarray
    disp_cs: np.ndarray
    cs_rotation: dict[int, np.ndarray] = field(default_factory=dict)
    cs_origin: dict[int, np.ndarray] = field(default_factory=dict)
    trace_lines: list[tuple[str, list[int]]] = field(default_factory=list)

    def direction(self, node: int, dof: int) -> np.ndarray:
        """Global unit vector of a UFF direction code (+-1, +-2, +-3 = x, y, z) at ``node``."""
        if abs(dof) not in (1, 2, 3):
            raise ConfigError(f"UFF direction {dof} at node {node} is not a translation (+-1, +-2, +-3)")
        hits = np.flatnonzero(self.node_nums == node)
        if not hits.size:
            raise ConfigError(f"UFF node {node} is not among the {self.node_nums.size} nodes of the geometry")
        cs = int(self.disp_cs[hits[0]])
        R = self.cs_rotation.get(cs, np.eye(3))
        return np.sign(dof) * R[:, abs(dof) - 1]


@dataclass(frozen=True)
class UffContent:
    functions: list[UffFunction]
    geometry: UffGeometry | None
    dataset_types: list[int]


def _rotation(origin, x_point, xz_point) -> np.ndarray:
    """Columns e_x, e_y, e_z of a coordinate system given by its origin, a point on +x and a point
    in the xz plane (dataset 18 / 2420 definition)."""
    o = np.asarray(origin, float)
    ex = np.asarray(x_point, float) - o
    ex /= np.linalg.norm(ex)
    v = np.asarray(xz_point, float) - o
    ez = v - (v @ ex) * ex
    ez /= np.linalg.norm(ez)
    return np.column_stack([ex, np.cross(ez, ex), ez])


def _pyuff():
    import pyuff

    return pyuff


def read_uff(path: str | Path) -> UffContent:
    """Read every dataset of a UFF file; functions 58/58b and geometry 15/2411/18/82 are kept."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: UFF file not found")
    types = uff_checks.check_structure(path, path.read_bytes())
    pyuff = _pyuff()
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise ConfigError(f"{path}: not a readable UFF file ({exc})") from exc
    sets = [sets] if isinstance(sets, dict) else sets
    uff_checks.check_types(path, types, sets)
    _check_sets(path, sets)
    functions: list[UffFunction] = []
    nodes = None
    cs_rot: dict[int, np.ndarray] = {}
    cs_org: dict[int, np.ndarray] = {}
    traces: list[tuple[str, list[int]]] = []
    for k, s in enumerate(sets):
        t = s.get("type")
        if t == 58:
            data = np.asarray(s["data"])
            functions.append(
                UffFunction(
                    name=str(s.get("id1", "")).strip(),
                    func_type=int(s.get("func_type", 0)),
                    x=np.asarray(s["x"], dtype=float),
                    data=data,
                    unit=str(s.get("ordinate_axis_units_lab", "")).strip(),
                    x_unit=str(s.get("abscissa_axis_units_lab", "")).strip(),
                    rsp_node=int(s.get("rsp_node", 0)),
                    rsp_dir=int(s.get("rsp_dir", 0)),
                    ref_node=int(s.get("ref_node", 0)),
                    ref_dir=int(s.get("ref_dir", 0)),
                    description=str(s.get("id2", "")).strip(),
                )
            )
        elif t in (15, 2411):
            nodes = s
        elif t == 18:
            for i, num in enumerate(s["cs_num"]):
                if int(s["ref_cs_num"][i]) != 0:
                    raise ConfigError(
                        f"{path}: dataset {k} coordinate system {int(num)} is defined in system "
                        f"{int(s['ref_cs_num'][i])}; only systems defined in the global one are supported"
                    )
                cs_rot[int(num)] = _rotation(s["ref_o"][i], s["x_point"][i], s["xz_point"][i])
                cs_org[int(num)] = np.asarray(s["ref_o"][i], float)
        elif t == 82:
            traces.append((str(s.get("id", "")).strip(), [int(n) for n in np.asarray(s["nodes"])[: int(s["n_nodes"])]]))
    geometry = None
    if nodes is not None:
        xyz = np.column_stack([nodes["x"], nodes["y"], nodes["z"]]).astype(float)
        def_cs = np.asarray(nodes["def_cs"], dtype=int)
        for i, cs in enumerate(def_cs):
            if cs:
                if cs not in cs_rot:
                    raise ConfigError(f"{path}: node {int(nodes['node_nums'][i])} uses undefined coordinate system {cs}")
                xyz[i] = cs_org[cs] + cs_rot[cs] @ xyz[i]
        geometry = UffGeometry(
            node_nums=np.asarray(nodes["node_nums"], dtype=int),
            xyz=xyz,
            disp_cs=np.asarray(nodes["disp_cs"], dtype=int),
            cs_rotation=cs_rot,
            cs_origin=cs_org,
            trace_lines=traces,
        )
    return UffContent(functions, geometry, [int(s.get("type", 0)) for s in sets])


def _check_sets(path: Path, sets: list[dict]) -> None:
    """Each parsed set against its own header (``uff_checks``)."""
    checks = {58: uff_checks.check_function, 15: uff_checks.check_nodes, 2411: uff_checks.check_nodes,
              82: uff_checks.check_trace}
    for index, s in enumerate(sets, start=1):
        check = checks.get(s.get("type"))
        if check is not None:
            check(path, index, s)
    uff_checks.check_references(path, sets)


def time_function(name: str, data: np.ndarray, dt: float, unit: str, *, node: int = 0, direction: int = 0) -> UffFunction:
    """A time record as a dataset-58 function."""
    data = np.asarray(data, dtype=float)
    return UffFunction(name, FUNC_TIME, np.arange(data.size) * dt, data, unit, "s", node, direction)


def write_uff(
    path: str | Path,
    *,
    functions: list[UffFunction] = (),
    geometry: UffGeometry | None = None,
    binary: bool = True,
    node_dataset: int = 15,
    overwrite: bool = False,
) -> None:
    """Write functions (58, binary 58b by default: doubles, lossless), coordinate systems (18, the
    nodes' displacement systems), nodes (15 or 2411, global coordinates) and trace lines (82)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise ConfigError(f"{path}: file exists; refusing to overwrite")
    if node_dataset not in (15, 2411):
        raise ConfigError(f"node dataset {node_dataset} must be 15 or 2411")
    pyuff = _pyuff()
    sets = []
    if geometry is not None:
        used = sorted({int(c) for c in geometry.disp_cs if c})
        if used:
            # the displacement systems the nodes refer to, as origin + x point + xz point
            R = [geometry.cs_rotation[c] for c in used]
            o = [geometry.cs_origin.get(c, np.zeros(3)) for c in used]
            sets.append(
                pyuff.prepare_18(
                    cs_num=used, cs_type=[0] * len(used), ref_cs_num=[0] * len(used), color=[8] * len(used),
                    method=[1] * len(used), cs_name=[f"CS{c}" for c in used], ref_o=[oi.tolist() for oi in o],
                    x_point=[(oi + r[:, 0]).tolist() for oi, r in zip(o, R)],
                    xz_point=[(oi + r[:, 0] + r[:, 2]).tolist() for oi, r in zip(o, R)],
                    return_full_dict=True,
                )
            )
        n = geometry.node_nums.size
        prep = pyuff.prepare_15 if node_dataset == 15 else pyuff.prepare_2411
        sets.append(
            prep(
                node_nums=geometry.node_nums.tolist(), def_cs=[0] * n,
                disp_cs=geometry.disp_cs.tolist(), color=[8] * n,
                x=geometry.xyz[:, 0].tolist(), y=geometry.xyz[:, 1].tolist(), z=geometry.xyz[:, 2].tolist(),
                return_full_dict=True,
            )
        )
        for i, (name, nodes) in enumerate(geometry.trace_lines, start=1):
            sets.append(
                pyuff.prepare_82(trace_num=i, n_nodes=len(nodes), color=8, id=name or f"trace {i}",
                                 nodes=np.asarray(nodes, dtype=int), return_full_dict=True)
            )
    for f in functions:
        complex_data = np.iscomplexobj(f.data)
        fields = dict.fromkeys(_58_ZERO_FIELDS, 0) | dict.fromkeys(_58_LABEL_FIELDS, "NONE")
        fields.update(
            binary=int(binary), id1=f.name or "NONE", id2=f.description or "NONE",
            func_type=f.func_type, z_axis_value=0.0, rsp_node=f.rsp_node, rsp_dir=f.rsp_dir,
            ref_node=f.ref_node, ref_dir=f.ref_dir,
            ord_data_type=ORD_COMPLEX_DOUBLE if complex_data else ORD_REAL_DOUBLE,
            num_pts=f.data.size, abscissa_spacing=1, abscissa_min=float(f.x[0]),
            abscissa_inc=float(f.x[1] - f.x[0]) if f.x.size > 1 else 1.0,
            abscissa_spec_data_type=17 if f.is_time else 18,
            abscissa_axis_units_lab=f.x_unit or "NONE", ordinate_axis_units_lab=f.unit or "NONE",
            data=f.data, x=f.x, return_full_dict=True,
        )
        d = pyuff.prepare_58(**fields)
        sets.append(d)
    if not sets:
        raise ConfigError(f"{path}: nothing to write (no functions and no geometry)")
    # pyuff's "overwrite" mode truncates the file again after a first binary 58 set's header and data:
    # start from an empty file and add every set
    path.write_bytes(b"")
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
