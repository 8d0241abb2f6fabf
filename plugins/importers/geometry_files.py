"""A structure's geometry from a TOML or CSV table or from UFF 15/82, and written back to UFF
15/82 with mode shapes as UFF 55 (docs/geometry.md).

TOML::

    units = "m"                               # or "mm": the coordinates' unit
    nodes = [[1, 0.0, 0.0, 0.0], ...]         # id, x, y, z
    lines = [[1, 5], ...]                     # node pairs
    faces = [[5, 6, 7, 8]]                    # node polygons (3 or more)
    fixed = [1, 2, 3, 4]                      # nodes that do not move
    sensors = [["ch1", 11, "-x"], ...]        # channel, node, direction (+x..-z or [dx, dy, dz])
    [[rigid]]                                 # nodes moving as one rigid body
    name = "top floor"
    nodes = [5, 6, 7, 8, 11, 12, 13]

CSV: one row per entry, its first field its kind: ``units,mm``; ``node,ID,X,Y,Z``;
``line,N1,N2``; ``face,N1,N2,N3[,...]``; ``fixed,N1[,...]``; ``rigid,NAME,N1[,...]``;
``sensor,CHANNEL,NODE,DIRECTION`` (``+x`` or ``dx dy dz``). Lines starting with ``#`` are comments.
"""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path

import numpy as np

from odsuite.api import ConfigError, check_text_file
from odsuite.api import Geometry, GeometrySensor, parse_direction

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254, "ft": 0.3048}
_KINDS = ("units", "node", "line", "face", "fixed", "rigid", "sensor")


def _int(value, where: str, field: str) -> int:
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {field}: {value!r} is not a node number") from None
    if not np.isfinite(f) or f != int(f) or abs(f) >= 2**31:
        raise ConfigError(f"{where}: {field}: {value!r} is not a node number (a whole number below 2^31)")
    return int(f)


def _float(value, where: str, field: str) -> float:
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {field}: {value!r} is not a number") from None
    if not np.isfinite(f):
        raise ConfigError(f"{where}: {field}: {value!r} is not a finite number")
    return f


def _scale(units, where: str) -> float:
    if str(units).strip().lower() not in LENGTH_UNITS:
        raise ConfigError(f"{where}: units: {units!r} is not one of {', '.join(LENGTH_UNITS)}")
    return LENGTH_UNITS[str(units).strip().lower()]


def _sensor(entry, where: str) -> GeometrySensor:
    if isinstance(entry, dict):
        entry = [entry.get("channel"), entry.get("node"), entry.get("direction")]
    if not isinstance(entry, (list, tuple)) or len(entry) != 3 or entry[0] in (None, ""):
        raise ConfigError(f"{where}: sensors: {entry!r} is not [channel, node, direction]")
    return GeometrySensor(str(entry[0]).strip(), _int(entry[1], where, f"sensor {entry[0]!r} node"),
                          parse_direction(entry[2], f"{where}: sensor {entry[0]!r}"))


def _assemble(name, where, scale, nodes, lines, faces, fixed, rigid, sensors) -> Geometry:
    if not nodes:
        raise ConfigError(f"{where}: nodes: none given")
    for n in nodes:
        if not isinstance(n, (list, tuple)):
            raise ConfigError(f"{where}: nodes: {n!r} is not [id, x, y, z]")
        if len(n) != 4:
            raise ConfigError(f"{where}: node {n[0] if n else ''!r}: {max(len(n) - 1, 0)} coordinates, "
                              "expected x, y, z")
    ids = [_int(n[0], where, "node id") for n in nodes]
    xyz = [[_float(v, where, f"node {ids[k]} coordinate") * scale for v in n[1:]] for k, n in enumerate(nodes)]
    for l in lines:
        if not isinstance(l, (list, tuple)) or len(l) != 2:
            raise ConfigError(f"{where}: line {l!r}: a line joins 2 nodes")
    for f in faces:
        if not isinstance(f, (list, tuple)):
            raise ConfigError(f"{where}: face {f!r}: expected a list of 3 or more nodes")
    return Geometry(name, np.array(ids), np.array(xyz, dtype=float).reshape(len(ids), 3),
                    np.array([[_int(v, where, "line node") for v in l] for l in lines], dtype=int).reshape(-1, 2),
                    tuple(tuple(_int(v, where, "face node") for v in f) for f in faces),
                    tuple(sensors), tuple(_int(v, where, "fixed node") for v in fixed),
                    tuple((str(n), tuple(_int(v, where, f"rigid {n!r} node") for v in g)) for n, g in rigid), where)


def _text(path: str | Path, encoding: str) -> str:
    """A geometry table's text; a pipe, a device or a file beyond the free memory refused before
    reading (a FIFO would block, /dev/zero never ends)."""
    check_text_file(Path(path), "geometry table")
    try:
        return Path(path).read_text(encoding=encoding)
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not a readable text file: {exc}") from None


def _toml_entries(path: str | Path) -> dict:
    """A TOML geometry table's fields, each checked for its shape."""
    where = str(path)
    try:
        doc = tomllib.loads(_text(path, "utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where}: not a readable TOML file: {exc}") from None
    except RecursionError:  # tomllib recurses per nesting level
        raise ConfigError(f"{where}: not a geometry table: nested too deep") from None
    unknown = sorted(set(doc) - {"units", "nodes", "lines", "faces", "fixed", "rigid", "sensors", "name"})
    if unknown:
        raise ConfigError(f"{where}: unknown field {unknown[0]!r} (fields: units, nodes, lines, faces, fixed, rigid, "
                          "sensors)")
    for key in ("nodes", "lines", "faces", "fixed", "rigid", "sensors"):
        if not isinstance(doc.get(key, []), list):
            raise ConfigError(f"{where}: {key}: expected a list, got {doc[key]!r}")
    rigid = []
    for g in doc.get("rigid", []):
        if not isinstance(g, dict) or not isinstance(g.get("nodes"), list):
            raise ConfigError(f"{where}: rigid: {g!r} is not a table with name and a list of nodes")
        rigid.append((str(g.get("name", f"group {len(rigid) + 1}")), g["nodes"]))
    return {"nodes": doc.get("nodes", []), "lines": doc.get("lines", []), "faces": doc.get("faces", []),
            "fixed": doc.get("fixed", []), "rigid": rigid, "scale": _scale(doc.get("units", "m"), where),
            "sensors": [_sensor(s, where) for s in doc.get("sensors", [])]}


def read_geometry_toml(path: str | Path, name: str) -> Geometry:
    e = _toml_entries(path)
    return _assemble(name, str(path), e["scale"], e["nodes"], e["lines"], e["faces"], e["fixed"], e["rigid"],
                     e["sensors"])


def _csv_entries(path: str | Path) -> dict:
    where = str(path)
    text = _text(path, "utf-8-sig")
    e = {"nodes": [], "lines": [], "faces": [], "fixed": [], "rigid": [], "sensors": [], "scale": 1.0}
    for k, row in enumerate(csv.reader(text.splitlines()), start=1):
        row = [c.strip() for c in row]
        while row and row[-1] == "":
            row.pop()
        if not row or row[0].startswith("#"):
            continue
        kind, rest = row[0].lower(), row[1:]
        here = f"{where}: line {k}"
        if kind not in _KINDS:
            raise ConfigError(f"{here}: row kind {row[0]!r} is not one of {', '.join(_KINDS)}")
        if kind == "units":
            e["scale"] = _scale(rest[0] if rest else "", here)
        elif kind == "rigid":
            if len(rest) < 2:
                raise ConfigError(f"{here}: rigid: expected NAME,N1[,...]")
            e["rigid"].append((rest[0], rest[1:]))
        elif kind == "sensor":
            e["sensors"].append(_sensor(rest, here))
        elif kind == "fixed":
            e["fixed"] += rest
        else:
            e[kind + "s"].append(rest)
    return e


def read_geometry_csv(path: str | Path, name: str) -> Geometry:
    e = _csv_entries(path)
    return _assemble(name, str(path), e["scale"], e["nodes"], e["lines"], e["faces"], e["fixed"], e["rigid"],
                     e["sensors"])


def read_geometry_uff(path: str | Path, name: str, sensors_file: str | Path | None = None) -> Geometry:
    """Nodes (15/2411, global coordinates) and trace lines (82) of a UFF file; sensors, fixed
    nodes, rigid groups and faces from ``sensors_file`` (a TOML or CSV geometry table without
    nodes), as UFF 15/82 holds none of them."""
    from odsuite_plugins.importers.uff import read_uff

    content = read_uff(path)
    g = content.geometry
    if g is None or not g.node_nums.size:
        raise ConfigError(f"{path}: no nodes (UFF dataset 15 or 2411) to make a geometry of")
    lines = []
    for _, trace in g.trace_lines:
        lines += [(int(a), int(b)) for a, b in zip(trace[:-1], trace[1:]) if a and b and a != b]
    extra = dict(faces=(), sensors=(), fixed=(), rigid=())
    if sensors_file is not None:
        node_rows = [[int(n), *map(float, xyz)] for n, xyz in zip(g.node_nums, g.xyz)]
        more = _read_table(sensors_file, name, node_rows)
        extra = dict(faces=more.faces, sensors=more.sensors, fixed=more.fixed, rigid=more.rigid)
    return Geometry(name, g.node_nums.astype(int), np.asarray(g.xyz, float),
                    np.array(list(dict.fromkeys(lines)), dtype=int).reshape(-1, 2), where=str(path), **extra)


def _read_table(path: str | Path, name: str, node_rows: list) -> Geometry:
    """A sensor table (TOML or CSV; its own nodes, if any, are added to the file's) read against
    ``node_rows`` (id, x, y, z in m)."""
    path = Path(path)
    e = _toml_entries(path) if path.suffix.lower() == ".toml" else _csv_entries(path)
    for n in e["nodes"]:
        if not isinstance(n, (list, tuple)) or not n:
            raise ConfigError(f"{path}: nodes: {n!r} is not [id, x, y, z]")
    own = [[n[0], *(_float(v, str(path), "node coordinate") * e["scale"] for v in n[1:])] for n in e["nodes"]]
    return _assemble(name, str(path), 1.0, node_rows + own, e["lines"], e["faces"], e["fixed"], e["rigid"],
                     e["sensors"])


def read_geometry(path: str | Path, name: str, sensors_file: str | Path | None = None) -> Geometry:
    """A geometry file by its suffix: .toml, .csv, .uff/.unv."""
    suffix = Path(path).suffix.lower()
    if suffix in (".uff", ".unv"):
        return read_geometry_uff(path, name, sensors_file)
    if sensors_file is not None:
        raise ConfigError(f"{path}: --sensors is for a UFF geometry; a {suffix} table holds its sensors itself")
    if suffix == ".toml":
        return read_geometry_toml(path, name)
    if suffix == ".csv":
        return read_geometry_csv(path, name)
    raise ConfigError(f"{path}: a geometry is a .toml, .csv or .uff/.unv file, not {suffix or 'a file without suffix'}")


def write_geometry_uff(path: str | Path, geom: Geometry, modes=(), *, overwrite: bool = False) -> None:
    """Nodes (15), the lines as one trace line (82, pen up between lines) and ``modes`` as UFF 55:
    ``modes`` is a sequence of (frequency Hz, damping ratio, node motions (nodes, 3) complex)."""
    from odsuite_plugins.importers.uff import UffGeometry, _pyuff, write_uff

    path = Path(path)
    trace = [int(v) for a, b in geom.lines.tolist() for v in (a, b, 0)][:-1]
    ug = UffGeometry(node_nums=geom.node_ids, xyz=geom.xyz, disp_cs=np.zeros(geom.node_ids.size, int),
                     trace_lines=[(geom.name or "lines", trace)] if trace else [])
    write_uff(path, geometry=ug, binary=False, overwrite=overwrite)
    if not modes:
        return
    pyuff = _pyuff()
    uff = pyuff.UFF(str(path))
    sets = []
    for k, (f, zeta, motion) in enumerate(modes, start=1):
        m = np.asarray(motion, dtype=complex)
        lam = -zeta * 2 * np.pi * f + 1j * 2 * np.pi * f * np.sqrt(max(0.0, 1 - zeta ** 2))
        sets.append(pyuff.prepare_55(
            model_type=1, id1="odsuite mode shapes", id2=f"mode {k}", id3=f"{f:.6g} Hz", id4="NONE", id5="NONE",
            analysis_type=3, data_ch=2, spec_data_type=8, data_type=5, n_data_per_node=3,
            r1=m[:, 0], r2=m[:, 1], r3=m[:, 2], node_nums=geom.node_ids.astype(int), load_case=1,
            mode_n=k, eig=lam, modal_a=0j, modal_b=0j))  # no r4-r6: three values per node
    uff.write_sets(sets, mode="add")
