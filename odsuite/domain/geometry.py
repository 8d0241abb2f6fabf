"""A structure's geometry that is not a set of rigid plates: nodes, lines and faces, the sensors
placed on nodes with their directions, and how unmeasured nodes follow the measured ones.

The rule (:meth:`Geometry.motion_matrix`), linear in the sensors' values, in this order:

1. a node in a ``rigid`` group moves with the group's rigid body (3 translations and 3 small
   rotations about the group's centroid) fitted by least squares to every sensor on the group's
   nodes; motions the sensors do not see (e.g. a floor's vertical motion seen by horizontal sensors
   only) are left undetermined;
2. any other node with sensors moves by the least-squares solution of its sensors' readings
   (reading = direction . motion); axes outside the span of its sensors stay undetermined;
3. a ``fixed`` node does not move;
4. every undetermined axis of a node is the inverse-distance-weighted mean (power 2) of that axis
   at the nodes where it is determined by 1-3 (zero when none is).

Coordinates are metres in one global frame; directions are unit vectors in that frame.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from odsuite.domain.errors import ConfigError
from odsuite.domain.rig import SIZE_MAX

#: the inverse-distance weights' power (documented in docs/geometry.md)
IDW_POWER = 2.0
AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0), "+z": (0, 0, 1), "-z": (0, 0, -1),
        "x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


@dataclass(frozen=True)
class GeometrySensor:
    """A single-axis sensor: the record's channel name, the node it sits on, its direction (unit)."""

    channel: str
    node: int
    direction: tuple[float, float, float]


def parse_direction(value, where: str) -> tuple[float, float, float]:
    """'+x' / '-y' / 'z' or three numbers -> a unit vector; anything else one line naming it."""
    if isinstance(value, str):
        key = value.strip().lower()
        if key in AXES:
            return tuple(float(v) for v in AXES[key])
        parts = key.replace(";", " ").replace(",", " ").split()
    else:
        parts = value
    try:
        v = np.array([float(p) for p in parts], dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: direction {value!r} is neither +x,-x,+y,-y,+z,-z nor three numbers") from None
    n = float(np.linalg.norm(v)) if v.shape == (3,) else 0.0
    if v.shape != (3,) or not np.isfinite(n) or n == 0:
        raise ConfigError(f"{where}: direction {value!r} is neither +x,-x,+y,-y,+z,-z nor three numbers "
                          "(not all zero)")
    return tuple(float(c) for c in v / n)


@dataclass(frozen=True, eq=False)
class Geometry:
    """Nodes (``node_ids``, ``xyz`` in m), ``lines`` (pairs of node ids), ``faces`` (node-id
    polygons), ``sensors``, ``fixed`` node ids and ``rigid`` groups ((name, node ids), ...)."""

    name: str
    node_ids: np.ndarray
    xyz: np.ndarray
    lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), int))
    faces: tuple[tuple[int, ...], ...] = ()
    sensors: tuple[GeometrySensor, ...] = ()
    fixed: tuple[int, ...] = ()
    rigid: tuple[tuple[str, tuple[int, ...]], ...] = ()
    where: str = "geometry"

    def __post_init__(self) -> None:
        w = self.where
        ids = _numbers(self.node_ids, w, "node ids")
        xyz = _numbers(self.xyz, w, "node coordinates")
        if ids.ndim != 1 or ids.size == 0:
            raise ConfigError(f"{w}: nodes: none given")
        bad = np.flatnonzero(~_whole(ids))
        if bad.size:
            raise ConfigError(f"{w}: node id {ids[bad[0]]:g} is not a node number (a whole number below 2^31)")
        if xyz.shape != (ids.size, 3):
            raise ConfigError(f"{w}: nodes: coordinates have shape {xyz.shape}, expected ({ids.size}, 3)")
        bad = np.flatnonzero(~np.isfinite(xyz).all(axis=1))
        if bad.size:
            raise ConfigError(f"{w}: node {int(ids[bad[0]])}: coordinates {xyz[bad[0]].tolist()} are not finite")
        bad = np.flatnonzero(np.abs(xyz).max(axis=1) > SIZE_MAX)
        if bad.size:
            raise ConfigError(f"{w}: node {int(ids[bad[0]])}: coordinates {xyz[bad[0]].tolist()} m lie beyond "
                              f"{SIZE_MAX:g} m of the origin")
        uniq, counts = np.unique(ids, return_counts=True)
        if (counts > 1).any():
            raise ConfigError(f"{w}: node {int(uniq[counts > 1][0])} is given twice")
        object.__setattr__(self, "node_ids", ids.astype(int))
        object.__setattr__(self, "xyz", xyz)
        lines = _numbers(self.lines, w, "lines")
        if lines.size % 2 or (lines.ndim == 2 and lines.shape[1] != 2 and lines.size) or not _whole(lines).all():
            raise ConfigError(f"{w}: lines: expected pairs of node ids, got shape {lines.shape}")
        object.__setattr__(self, "lines", lines.astype(int).reshape(-1, 2))
        object.__setattr__(self, "faces", tuple(_node_ids(f, w, "face") for f in _sequence(self.faces, w, "faces")))
        object.__setattr__(self, "fixed", _node_ids(self.fixed, w, "fixed"))
        rigid = []
        for group in _sequence(self.rigid, w, "rigid"):
            if not isinstance(group, (list, tuple)) or len(group) != 2 or not isinstance(group[0], str):
                raise ConfigError(f"{w}: rigid: {_brief(group)} is not a group (name, node ids)")
            rigid.append((group[0], _node_ids(group[1], w, f"rigid {group[0]!r}")))
        object.__setattr__(self, "rigid", tuple(rigid))
        for sensor in _sequence(self.sensors, w, "sensors"):
            if not isinstance(sensor, GeometrySensor) or not isinstance(sensor.channel, str):
                raise ConfigError(f"{w}: sensors: {_brief(sensor)} is not a sensor (channel, node, direction)")
        object.__setattr__(self, "sensors", tuple(
            GeometrySensor(s.channel, _node_ids([s.node], w, f"sensor {s.channel!r} node")[0],
                           parse_direction(s.direction, f"{w}: sensor {s.channel!r}")) for s in self.sensors))
        known = set(int(i) for i in ids)
        for what, nodes in ([("line", tuple(l)) for l in lines.tolist()] + [("face", tuple(f)) for f in self.faces]
                            + [("fixed", tuple(self.fixed))] + [(f"rigid {n!r}", tuple(g)) for n, g in self.rigid]
                            + [(f"sensor {s.channel!r}", (s.node,)) for s in self.sensors]):
            missing = [n for n in nodes if int(n) not in known]
            if missing:
                raise ConfigError(f"{w}: {what}: node {missing[0]} is not among the geometry's nodes")
        for f in self.faces:
            if len(f) < 3:
                raise ConfigError(f"{w}: face {list(f)}: a face needs 3 or more nodes")
        names = [s.channel for s in self.sensors]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f"{w}: sensor channel {dup[0]!r} is placed twice")
        sensed = {s.node for s in self.sensors}
        clash = sorted(sensed & set(self.fixed))
        if clash:
            raise ConfigError(f"{w}: node {clash[0]} is fixed but carries sensor(s)")
        grouped = [n for _, g in self.rigid for n in g]
        twice = sorted({n for n in grouped if grouped.count(n) > 1})
        if twice:
            raise ConfigError(f"{w}: node {twice[0]} is in two rigid groups")

    def index(self, node: int) -> int:
        hits = np.flatnonzero(self.node_ids == int(node))
        if not hits.size:
            raise ConfigError(f"{self.where}: node {node} is not among the geometry's nodes")
        return int(hits[0])

    @property
    def channels(self) -> list[str]:
        return [s.channel for s in self.sensors]

    def edges(self) -> np.ndarray:
        """Index pairs (k, 2) of every line and face edge, each once."""
        pairs = [tuple(l) for l in self.lines.tolist()]
        for f in self.faces:
            pairs += [(f[k], f[(k + 1) % len(f)]) for k in range(len(f))]
        out = dict.fromkeys(tuple(sorted((self.index(a), self.index(b)))) for a, b in pairs)
        return np.array(list(out), dtype=int).reshape(-1, 2)

    def size(self) -> float:
        """The structure's largest extent (m), the scale of its drawing."""
        span = self.xyz.max(axis=0) - self.xyz.min(axis=0)
        return float(max(span.max(), 1e-9))

    def motion_matrix(self, channels: Sequence[str] | None = None) -> np.ndarray:
        """T (nodes, 3, channels): node displacements = T @ the sensors' values, by the module's
        rule; ``channels`` (default: every sensor's) are the values' order. A channel with no
        sensor on the geometry is refused in one line."""
        channels = list(self.channels if channels is None else channels)
        by_name = {s.channel: s for s in self.sensors}
        absent = [c for c in channels if c not in by_name]
        if absent:
            raise ConfigError(f"{self.where}: channel {absent[0]!r} has no sensor on the geometry "
                              f"(sensors: {', '.join(by_name) or 'none'})")
        col = {c: k for k, c in enumerate(channels)}
        n = self.node_ids.size
        T = np.zeros((n, 3, len(channels)))
        known = np.zeros((n, 3), bool)
        in_group = set()
        for _, group in self.rigid:
            idx = [self.index(g) for g in group]
            in_group |= set(idx)
            sens = [s for s in self.sensors if s.node in set(group) and s.channel in col]
            if not sens:
                continue
            centre = self.xyz[idx].mean(axis=0)
            A = np.array([np.concatenate([d, np.cross(self.xyz[self.index(s.node)] - centre, d)])
                          for s in sens for d in [np.asarray(s.direction)]])
            Ainv = np.linalg.pinv(A, rcond=1e-9)
            P = Ainv @ A  # projector onto the rigid motions the sensors see
            cols = [col[s.channel] for s in sens]
            for i in idx:
                r = self.xyz[i] - centre
                B = np.hstack([np.eye(3), -_cross_matrix(r)])  # u = t + theta x r
                T[i][:, cols] = B @ Ainv
                known[i] = np.linalg.norm(B - B @ P, axis=1) < 1e-6 * max(1.0, np.linalg.norm(r))
        for node in sorted({s.node for s in self.sensors}):
            i = self.index(node)
            if i in in_group:
                continue
            sens = [s for s in self.sensors if s.node == node and s.channel in col]
            if not sens:
                continue
            D = np.array([s.direction for s in sens], dtype=float)
            Dinv = np.linalg.pinv(D, rcond=1e-9)
            T[i][:, [col[s.channel] for s in sens]] = Dinv
            known[i] = np.linalg.norm(np.eye(3) - Dinv @ D, axis=1) < 1e-6
        for node in self.fixed:
            i = self.index(node)
            T[i] = 0.0
            known[i] = True
        for a in range(3):
            src = np.flatnonzero(known[:, a])
            for i in np.flatnonzero(~known[:, a]):
                if not src.size:
                    continue
                d = np.linalg.norm(self.xyz[src] - self.xyz[i], axis=1)
                w = 1.0 / np.maximum(d, 1e-12) ** IDW_POWER
                T[i, a] = (w / w.sum()) @ T[src, a]
        return T

    def node_motion(self, values: Mapping[str, complex | np.ndarray]) -> np.ndarray:
        """Node displacements (nodes, 3, ...) from each channel's value (a number, or a series)."""
        names = list(values)
        v = np.array([np.asarray(values[c]) for c in names])
        return np.tensordot(self.motion_matrix(names), v, axes=([2], [0]))


def _brief(value) -> str:
    text = " ".join(repr(value).split())  # one line: an array's repr spans several
    return text if len(text) <= 60 else text[:57] + "..."


def _numbers(value, where: str, what: str) -> np.ndarray:
    """``value`` as an array of floats, or one line naming it."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: {what}: expected numbers, got {_brief(value)}") from None


def _whole(values: np.ndarray) -> np.ndarray:
    """Which values are node numbers: whole and below 2^31 (a C integer's range)."""
    with np.errstate(invalid="ignore"):
        return np.isfinite(values) & (np.round(values) == values) & (np.abs(values) < 2**31)


def _sequence(value, where: str, what: str) -> Sequence:
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
        raise ConfigError(f"{where}: {what}: expected a list, got {_brief(value)}")
    return value


def _node_ids(value, where: str, what: str) -> tuple[int, ...]:
    """A list of node numbers, or one line naming ``what``."""
    ids = _numbers(_sequence(value, where, what), where, what)
    if ids.ndim != 1 or not _whole(ids).all():
        raise ConfigError(f"{where}: {what}: expected node numbers, got {_brief(value)}")
    return tuple(int(v) for v in ids)


def _cross_matrix(r: np.ndarray) -> np.ndarray:
    """[r]x: [r]x @ v = r x v."""
    return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]], dtype=float)


#: the import kind a stored geometry has (``Project.write_import``)
GEOMETRY_KIND = "geometry"


def geometry_record(geom: Geometry) -> tuple[dict[str, tuple[np.ndarray, str, tuple[str, ...]]], dict]:
    """A geometry as stored: arrays (data, unit, dims) and JSON-ready attributes."""
    arrays = {"node_ids": (geom.node_ids, "1", ("node",)), "xyz": (geom.xyz, "m", ("node", "axis")),
              "lines": (geom.lines, "1", ("line", "end"))}
    attrs = {"faces": [list(map(int, f)) for f in geom.faces],
             "sensors": [[s.channel, int(s.node), list(s.direction)] for s in geom.sensors],
             "fixed": [int(n) for n in geom.fixed], "rigid": [[n, [int(v) for v in g]] for n, g in geom.rigid]}
    return arrays, attrs


def geometry_from_record(name: str, arrays: Mapping[str, np.ndarray], attrs: Mapping, where: str) -> Geometry:
    """The geometry :func:`geometry_record` stored; a field edited out of shape is one line naming it."""
    for field_name in ("node_ids", "xyz", "lines"):
        if field_name not in arrays:
            raise ConfigError(f"{where}: field {field_name!r} is missing")
    sensors = []
    for entry in _sequence(attrs.get("sensors", []), where, "field 'sensors'"):
        if not isinstance(entry, (list, tuple)) or len(entry) != 3 or not isinstance(entry[0], str):
            raise ConfigError(f"{where}: field 'sensors': expected [[channel, node, [dx, dy, dz]], ...], "
                              f"got {_brief(entry)}")
        sensors.append(GeometrySensor(*entry))
    return Geometry(name, arrays["node_ids"], arrays["xyz"], arrays["lines"],
                    tuple(_sequence(attrs.get("faces", []), where, "field 'faces'")), tuple(sensors),
                    attrs.get("fixed", []), tuple(_sequence(attrs.get("rigid", []), where, "field 'rigid'")), where)


def project_geometry(project, name: str | None = None) -> Geometry | None:
    """The geometry stored in an open project (``name``, else its only one; None when it has none)."""
    kinds = project.import_names()
    names = [n for n, k in kinds.items() if k == GEOMETRY_KIND]
    if name is None:
        if not names:
            return None
        if len(names) > 1:
            raise ConfigError(f"{project.path}: geometries {', '.join(names)}: name one with --geometry")
        name = names[0]
    elif name not in names:
        raise ConfigError(f"{project.path}: no geometry {name!r} (geometries: {', '.join(names) or 'none'})")
    arrays, attrs = project.read_import(name)
    return geometry_from_record(name, arrays, attrs, f"{project.path}: geometry {name!r}")
