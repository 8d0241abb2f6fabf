"""Universal File Format (UFF/UNV) through pyuff: functions (58/58b: time records, FRFs and the
other function types), nodes (15, 2411), coordinate systems (18), trace lines (82), header (151),
units (164) and mode shapes (55).

Node coordinates are returned in the global frame and in metres (a node defined in a local
coordinate system is transformed; lengths are divided by the 164 set's length factor); each node's
displacement coordinate system gives its measurement directions. A file cut short (a dataset
without its closing -1, a function with fewer points than its header announces) is refused naming
the dataset and what is missing.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from odsuite_plugins.importers import uff_checks
from odsuite.api import ConfigError

#: dataset 58 function types used here
FUNC_TIME = 1
FUNC_FRF = 4
#: dataset 58 ordinate data types: real double, complex double
ORD_REAL_DOUBLE = 4
ORD_COMPLEX_DOUBLE = 6
#: dataset 58 function types (record 6 field 1) by name, for the reasons given when one is skipped
FUNCTION_TYPES = {0: "general or unknown", 1: "time response", 2: "auto spectrum", 3: "cross spectrum",
                  4: "frequency response function", 5: "transmissibility", 6: "coherence", 7: "auto correlation",
                  8: "cross correlation", 9: "power spectral density", 10: "energy spectral density",
                  11: "probability density function", 12: "spectrum", 13: "cumulative frequency distribution",
                  14: "peaks valley", 15: "stress/cycles", 16: "strain/cycles", 17: "orbit", 18: "mode indicator",
                  19: "force pattern", 20: "partial power", 21: "partial coherence", 22: "eigenvalue",
                  23: "eigenvector", 24: "shock response spectrum", 25: "finite impulse response filter",
                  26: "multiple coherence", 27: "order function"}
#: dataset 58 specific data types (records 8, 9) of SI units: what a record measures
SPEC_TYPES = {"m": 8, "n": 13, "m/s": 11, "m/s^2": 12, "m/s2": 12, "pa": 15, "s": 17, "hz": 18}
#: dataset 164 units code 1: SI, metre and newton; factors 1
SI_UNITS_CODE = 1


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
    unit_exponents: tuple[int, int] = (0, 0)  # record 9: the ordinate's length and force units exponents
    dataset: int = 0  # its number in the file read (from 1), for messages; 0: not read from a file

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
class UffMode:
    """One dataset 55 (modal data): a mode's frequency (Hz), viscous damping ratio when given, and
    per node its values (translations, then rotations when the set holds six per node)."""

    name: str
    number: int
    frequency_hz: float
    damping_ratio: float
    node_nums: np.ndarray
    values: np.ndarray  # nodes x values per node


@dataclass(frozen=True)
class UffContent:
    functions: list[UffFunction]
    geometry: UffGeometry | None
    dataset_types: list[int]
    modes: list[UffMode] = field(default_factory=list)
    length_factor: float = 1.0  # dataset 164: file length units per metre
    header: dict = field(default_factory=dict)  # dataset 151, as pyuff reads it
    force_factor: float = 1.0  # dataset 164: file force units per newton
    units_description: str = ""  # dataset 164's


#: ordinate labels of values no length or force unit scales: UFF's "not specified", volts
UNIT_FREE_LABELS = ("", "none", "v")


def check_si_records(path: Path, content: UffContent, functions: list[UffFunction]) -> None:
    """Refuse records (58) of a file whose units (164) are not SI: their values are in the file's
    units (the SI value times the 164 factors to the record's exponents), while odsuite reads them
    by their unit labels as SI. They are not converted: the labels name SI units all the same, and
    writers often leave the exponents that would scale them at 0."""
    lf, ff = content.length_factor, content.force_factor
    if lf == 1.0 and ff == 1.0:
        return
    for f in functions:
        if f.unit.strip().lower() not in UNIT_FREE_LABELS or any(f.unit_exponents):
            raise ConfigError(f"{path}: dataset 164 gives the file's units as {content.units_description!r} "
                              f"(length factor {lf:g}, force factor {ff:g} per SI unit): record {f.name!r} "
                              f"({f.unit or 'NONE'}) would be read as SI; odsuite imports records in SI units only")


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


_SET_START = re.compile(rb"(?:^|\n)[ \t]*-1[ \t]*\r?\n[ \t]*(\d+)(b?)[^\n]*\n")


def read_uff(path: str | Path) -> UffContent:
    """Read every dataset of a UFF file; functions 58/58b, modes 55, geometry 15/2411/18/82, header
    151 and units 164 are kept (lengths in metres)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: UFF file not found")
    try:
        types = uff_checks.check_structure(path, path.read_bytes())
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror or exc})") from None
    pyuff = _pyuff()
    uff = None
    try:
        uff = pyuff.UFF(str(path))
        sets = uff.read_sets()
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise ConfigError(f"{path}: not a readable UFF file ({_unreadable_set(uff, types) or exc})") from exc
    sets = [sets] if isinstance(sets, dict) else sets
    uff_checks.check_types(path, types, sets)
    _check_sets(path, sets)
    functions: list[UffFunction] = []
    modes: list[UffMode] = []
    length_factor, force_factor, units, header = 1.0, 1.0, "", {}
    nodes = None
    cs_rot: dict[int, np.ndarray] = {}
    cs_org: dict[int, np.ndarray] = {}
    traces: list[tuple[str, list[int]]] = []
    for k, s in enumerate(sets):
        t = s.get("type")
        if t == 58:
            data = np.asarray(s["data"])
            if "num_pts" in s and data.size != int(s["num_pts"]):
                raise ConfigError(f"{path}: dataset {k} (58 {str(s.get('id1', '')).strip()!r}) holds {data.size} of "
                                  f"the {int(s['num_pts'])} points its header announces: the file is cut short")
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
                    unit_exponents=(int(s.get("ordinate_len_unit_exp", 0) or 0),
                                    int(s.get("ordinate_force_unit_exp", 0) or 0)),
                    dataset=k + 1,
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
        elif t == 55:
            per_node = int(s.get("n_data_per_node", 3))
            nums = np.asarray(s.get("node_nums", []), dtype=int)
            cols = [np.asarray(s.get(f"r{i}", []), dtype=complex) for i in range(1, per_node + 1)]
            if any(c.size != nums.size for c in cols):
                raise ConfigError(f"{path}: dataset {k} (55 mode {s.get('mode_n')}) holds values for "
                                  f"{min(c.size for c in cols)} of its {nums.size} nodes: the file is cut short")
            values = np.column_stack(cols) if cols else np.empty((nums.size, 0))
            if not np.any(values.imag):
                values = values.real
            modes.append(UffMode(str(s.get("id1", "")).strip(), int(s.get("mode_n", len(modes) + 1)),
                                 float(s.get("freq", np.nan)), float(s.get("modal_damp_vis", 0.0)), nums, values))
        elif t == 164:
            length_factor, force_factor = (_units_factor(path, k, s, name) for name in ("length", "force"))
            units = str(s.get("units_description", "")).strip()
        elif t == 151:
            header = {key: v for key, v in s.items() if key != "type"}
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
        # 164: a length in file units is the length in metres times the factor
        geometry = UffGeometry(
            node_nums=np.asarray(nodes["node_nums"], dtype=int),
            xyz=xyz / length_factor,
            disp_cs=np.asarray(nodes["disp_cs"], dtype=int),
            cs_rotation=cs_rot,
            cs_origin={c: o / length_factor for c, o in cs_org.items()},
            trace_lines=traces,
        )
    return UffContent(functions, geometry, [int(s.get("type", 0)) for s in sets], modes, length_factor, header,
                      force_factor, units)


#: dataset 164 factors (file units per SI unit) of real units: a nanometre's 1e9 to a kilometre's
#: 1e-3, a meganewton's 1e-6; beyond them coordinates are divided into overflow or nothing
UNITS_FACTOR_RANGE = (1e-9, 1e9)


def _units_factor(path: Path, index: int, s: dict, name: str) -> float:
    """A 164 set's length or force factor; a negative one mirrored every node, NaN made them NaN."""
    value = float(s.get(name, 1.0))
    low, high = UNITS_FACTOR_RANGE
    if not low <= value <= high:
        raise ConfigError(f"{path}: dataset {index + 1} (164 units {str(s.get('units_description', '')).strip()!r}) "
                          f"field {name!r}: expected a factor from {low:g} to {high:g} file units per SI unit, "
                          f"got {value:g}")
    return value


def _unreadable_set(uff, types: list[int]) -> str:
    """The first dataset pyuff cannot read and its reason ('dataset 1 (164): Error reading data-set
    #164'): reading them all, it says only 'Error when reading data-set(s).'; "" when none is found."""
    for k, kind in enumerate(types if uff is not None else ()):
        try:
            uff.read_sets(k)
        except Exception as exc:
            return f"dataset {k + 1} ({kind}): {exc.__context__ or exc}"
    return ""


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


def _spec_fields(f: UffFunction) -> dict:
    """Specific data types of a function's ordinate (and of an FRF's denominator, a force) from
    its SI unit; 0 (unknown) for units not listed."""
    unit = f.unit.strip().lower()
    if f.func_type == FUNC_FRF and unit.endswith("/n"):
        return {"ordinate_spec_data_type": SPEC_TYPES.get(unit[:-2].strip("()"), 0),
                "orddenom_spec_data_type": SPEC_TYPES["n"]}
    return {"ordinate_spec_data_type": SPEC_TYPES.get(unit, 0)}


def write_uff(
    path: str | Path,
    *,
    functions: list[UffFunction] = (),
    geometry: UffGeometry | None = None,
    binary: bool = True,
    node_dataset: int = 15,
    overwrite: bool = False,
) -> None:
    """Write the units (164: SI, metre and newton), functions (58, binary 58b by default: doubles,
    lossless; each with its function type and the specific data types of its ordinate, and of an
    FRF's denominator, from its unit), coordinate systems (18, the nodes' displacement systems),
    nodes (15 or 2411, global coordinates in m) and trace lines (82)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise ConfigError(f"{path}: file exists; refusing to overwrite")
    if node_dataset not in (15, 2411):
        raise ConfigError(f"node dataset {node_dataset} must be 15 or 2411")
    pyuff = _pyuff()
    sets = [pyuff.prepare_164(units_code=SI_UNITS_CODE, units_description="SI - mks (Newton)", temp_mode=2,
                              length=1.0, force=1.0, temp=1.0, temp_offset=273.15, return_full_dict=True)]
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
            **_spec_fields(f),
            abscissa_axis_units_lab=f.x_unit or "NONE", ordinate_axis_units_lab=f.unit or "NONE",
            data=f.data, x=f.x, return_full_dict=True,
        )
        d = pyuff.prepare_58(**fields)
        sets.append(d)
    if len(sets) == 1:
        raise ConfigError(f"{path}: nothing to write (no functions and no geometry)")
    # pyuff's "overwrite" mode truncates the file again after a first binary 58 set's header and data:
    # start from an empty file and add every set
    path.write_bytes(b"")
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
