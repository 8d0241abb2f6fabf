"""UFF files and projects: time records (dataset 58, time abscissa) imported as an experiment,
FRFs (dataset 58, function type 4) stored beside them as derived "frf"; an experiment exported as
time records, FRFs, geometry (15 or 2411) and trace lines (82) of the rig's plates and sensors.

Imported values are stored as the raw column in the file's units with a sensitivity that converts
them to SI (as for LabVIEW files, see :mod:`odsuite.analysis.modal_project`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from odsuite.api import write_output
from odsuite.api import ConfigError
from odsuite.api import physical
from odsuite_plugins.importers.columns import force_index, operating_note
from odsuite.api import DerivedArray, Excitation, Project, open_project
from odsuite.api import Rig
from odsuite_plugins.importers.rig_import import columns_to_channels, name_key, names_the_rig, onto_rig
from odsuite_plugins.importers.tables import UNITS, unit_key
from odsuite.api import CORNERS, plate_corners
from odsuite.api import ChannelInfo, SensorType, Systeminfo
from odsuite_plugins.importers.uff import (
    FUNC_FRF,
    FUNCTION_TYPES,
    UffFunction,
    UffGeometry,
    UffMode,
    check_si_records,
    read_uff,
    time_function,
    write_uff,
)
from odsuite.api import __version__

#: ordinate units labels (record 9 field 6, as ``unit_key`` spells them) of a record stored
#: without a rig -> (sensor type, V per SI unit): the other importers' and the SI units of records
#: other tools write (pyuff's samples hold a microphone's pressure in Pa), each in its own quantity
UFF_UNITS = UNITS | {"pa": (SensorType.PRESSURE, 1.0), "m": (SensorType.PROXIMITY, 1.0),
                     "m/s": (SensorType.VELOCITY, 1.0)}
#: UFF's "not specified": stored without a sensor
UFF_UNSPECIFIED = ("", "none")

#: Corners of a plate's top face (body z points down into the plate: z = 0 is the top) in drawing order.
_TOP_FACE = ("FLL", "FRL", "RRL", "RLL")


def _node_point(geometry: UffGeometry | None, node: int, direction: int) -> tuple[np.ndarray, np.ndarray] | None:
    if geometry is None or node not in geometry.node_nums or abs(direction) not in (1, 2, 3):
        return None
    return geometry.xyz[np.flatnonzero(geometry.node_nums == node)[0]], geometry.direction(node, direction)


def _nodes_arrays(geometry: UffGeometry) -> tuple[dict[str, DerivedArray], dict]:
    """A geometry as stored: node numbers, global coordinates (m) and each node's displacement
    system (columns: its x, y, z directions in the global frame); trace lines as an attribute."""
    axes = np.array([np.column_stack([geometry.direction(int(n), d) for d in (1, 2, 3)]) for n in geometry.node_nums])
    return ({"node_nums": DerivedArray(geometry.node_nums, "1", ("node",)),
             "xyz": DerivedArray(geometry.xyz, "m", ("node", "axis")),
             "directions": DerivedArray(axes, "1", ("node", "axis", "direction"))},
            {"trace_lines": [[name, [int(n) for n in nodes]] for name, nodes in geometry.trace_lines]})


def _modes_arrays(modes: list[UffMode], where: str) -> dict[str, DerivedArray]:
    nums = modes[0].node_nums
    for m in modes:
        if not np.array_equal(m.node_nums, nums) or m.values.shape != modes[0].values.shape:
            raise ConfigError(f"{where}: mode {m.number} ({m.frequency_hz:g} Hz) is given at other nodes than mode "
                              f"{modes[0].number}; modes of one import share their nodes")
    shapes = np.array([m.values for m in modes], dtype=complex)
    dims = ("mode", "node", "value")
    return {"frequency_hz": DerivedArray(np.array([m.frequency_hz for m in modes]), "Hz", ("mode",)),
            "damping_ratio": DerivedArray(np.array([m.damping_ratio for m in modes]), "1", ("mode",)),
            "mode_nodes": DerivedArray(nums, "1", ("node",)),
            "shape_real": DerivedArray(shapes.real, "1", dims), "shape_imag": DerivedArray(shapes.imag, "1", dims)}


def _frf_arrays(frfs: list[UffFunction], where: str) -> tuple[dict[str, DerivedArray], dict]:
    freq = frfs[0].x
    for f in frfs:
        if f.x.shape != freq.shape or not np.allclose(f.x, freq):
            raise ConfigError(f"{where}: FRF {f.name!r} has other frequency lines than FRF {frfs[0].name!r}")
    H = np.array([np.asarray(f.data, dtype=complex) for f in frfs])
    dims = ("output", "frequency")
    units = ";".join(f.unit for f in frfs)
    return ({"frequency": DerivedArray(freq, "Hz", ("frequency",)),
             "H_real": DerivedArray(H.real, units, dims), "H_imag": DerivedArray(H.imag, units, dims)},
            {"outputs": json.dumps([f.name for f in frfs]), "n_averages": 0,
             "nodes": json.dumps([[f.rsp_node, f.rsp_dir, f.ref_node, f.ref_dir] for f in frfs])})


def import_uff(project: str | Path, uff_path: str | Path, name: str, force_channel: str | None = None, *,
               force_point: np.ndarray | None = None, force_dir: np.ndarray | None = None,
               force_body: str | None = None) -> tuple[str, tuple[str, ...]]:
    """Add a UFF file to a project under ``name``; returns what was stored and notes for the user.

    Time records (58, function type 1) become experiment ``name`` (all of one length and sampling
    interval; the force channel is ``force_channel``, else the one record in newtons or named like
    a force, else the one at a node and direction the others name as their reference, else none: an
    operating record), with the file's FRFs as its derived "frf". On a project with a rig the
    records go onto the rig's sensors (:func:`_rig_mapping`; the hammer's ``force_point`` (m, rig
    frame) and ``force_dir`` default to the force record's node in the file). A file
    without time records is stored as import ``name``: its FRFs ("frf"), modes (55: "modes") or
    else its nodes ("nodes"), each with the file's nodes when it has some. Other function types
    (spectra, PSDs, coherences) are not records: they are named in a note, or refused when the file
    holds nothing else.
    """
    uff_path = Path(uff_path)
    content = read_uff(uff_path)
    if not content.dataset_types:
        raise ConfigError(f"{uff_path}: no UFF datasets found (not a UFF file, or cut short)")
    records = [f for f in content.functions if f.is_time]
    frfs = [f for f in content.functions if f.func_type == FUNC_FRF]
    others = [f for f in content.functions if not f.is_time and f.func_type != FUNC_FRF]
    skipped = [f"58 {f.name!r} is a {FUNCTION_TYPES.get(f.func_type, f'function of type {f.func_type}')} "
               f"(function type {f.func_type}), not a record" for f in others]
    if not records and not frfs and not content.modes and content.geometry is None:
        reason = "; ".join(skipped) or f"datasets {sorted(set(content.dataset_types))} hold no records, FRFs, modes or nodes"
        raise ConfigError(f"{uff_path}: nothing to import: {reason}")
    notes = tuple(f"{uff_path}: {s}: not imported" for s in skipped)
    check_si_records(uff_path, content, records + frfs)
    if records:
        return _import_records(project, uff_path, name, content, records, frfs, force_channel, notes,
                               (force_point, force_dir, force_body))
    arrays: dict[str, DerivedArray] = {}
    attrs: dict = {}
    if content.geometry is not None:
        more, attrs = _nodes_arrays(content.geometry)
        arrays |= more
    kind = "modes" if content.modes else "frf" if frfs else "nodes"
    if content.modes:
        arrays |= _modes_arrays(content.modes, str(uff_path))
    if frfs:
        more, frf_attrs = _frf_arrays(frfs, str(uff_path))
        arrays |= more
        attrs |= frf_attrs
    with open_project(project, "a") as p:
        p.write_import(name, kind, arrays, source=uff_path.name, attrs=attrs)
    counts = {"modes": f"{len(content.modes)} modes", "frf": f"{len(frfs)} FRFs",
              "nodes": f"{content.geometry.node_nums.size if content.geometry else 0} nodes"}
    extra = f", {content.geometry.node_nums.size} nodes" if kind != "nodes" and content.geometry else ""
    return f"{counts[kind]}{extra} as import {name!r} ({kind})", notes


def _import_records(project, uff_path: Path, name: str, content, records: list[UffFunction],
                    frfs: list[UffFunction], force_channel: str | None, notes: tuple[str, ...], hammer: tuple):
    first = records[0]
    dt = float(first.x[1] - first.x[0]) if first.x.size > 1 else 0.0
    if not dt > 0:
        raise ConfigError(f"{uff_path}: time record {first.name!r}: sampling interval must be > 0 s, got {dt!r}")
    names: list[str] = []
    for k, f in enumerate(records):
        if f.data.shape != first.data.shape:
            raise ConfigError(f"{uff_path}: time record {f.name!r} has {f.data.size} samples, "
                              f"record {first.name!r} {first.data.size}; records must be of one length")
        if np.iscomplexobj(f.data):
            raise ConfigError(f"{uff_path}: time record {f.name!r} holds complex values")
        step = float(f.x[1] - f.x[0]) if f.x.size > 1 else dt
        if not np.isclose(step, dt, rtol=1e-6):
            raise ConfigError(f"{uff_path}: time record {f.name!r} is sampled every {step!r} s, "
                              f"record {first.name!r} every {dt!r} s")
        names.append(f.name if f.name and f.name != "NONE" else f"ch{k}")
    units = [f.unit for f in records]
    fidx = force_index(names, units, force_channel, str(uff_path), UFF_UNITS)
    if fidx is None:
        fidx = _reference_index(records, names, str(uff_path))
    with open_project(project) as p:
        rig = p.rig
    if fidx is None and rig is not None and rig.force_channel is not None:  # a record named like the rig's hammer
        hammer_sensor = rig.sensor_on_channel(rig.force_channel)
        fidx = next((k for k, n in enumerate(names) if hammer_sensor and name_key(n) == name_key(hammer_sensor.name)), None)
    if rig is not None and (any(v is not None for v in hammer) or names_the_rig(rig, names)
                            or _rig_mapping(rig, records, fidx, str(uff_path), names, strict=False)):
        return _import_onto_rig(project, rig, uff_path, name, content, records, frfs, names, fidx,
                                _sampling_rate(dt), notes, hammer)
    if any(v is not None for v in hammer):
        raise ConfigError(f"{uff_path}: --force-point/--force-dir/--force-body need a project with a rig geometry")
    if rig is not None:
        notes += (f"{uff_path}: its records ({', '.join(names)}) are not the channels of rig {rig.name!r} (no UFF node, "
                  "name or count matches): stored as they are, without the rig's geometry",)
    names = [n if n not in names[:k] else f"{n}#{k}" for k, n in enumerate(names)]
    if fidx is None:
        notes += (operating_note(str(uff_path), names, units),)
    fs = _sampling_rate(dt)
    kinds = _record_units(uff_path, records, UFF_UNITS, UFF_UNSPECIFIED, "m/s^2, g, N, V, Pa, m, m/s or NONE")
    raw = np.column_stack([f.data for f in records]).astype(float)
    # values in engineering units, not volts: converter limits well above the peaks, so no false clipping
    limits = np.maximum(10.0, np.ceil(2 * np.abs(raw).max(axis=0)))
    channels = []
    for k, (n, (stype, sens)) in enumerate(zip(names, kinds, strict=True)):
        if k == fidx:
            stype, sens = SensorType.LOADCELL, 1.0
        channels.append(ChannelInfo(sensor_type=stype, location=n, sensitivity=sens, sampling_rate=fs,
                                    limit_high=float(limits[k]), limit_low=-float(limits[k])))
    excitation = None
    if fidx is not None:
        hit = _node_point(content.geometry, records[fidx].rsp_node, records[fidx].rsp_dir)
        point, direction = hit if hit is not None else (np.zeros(3), np.array([0.0, 0.0, 1.0]))
        excitation = Excitation(fidx, point, direction)
    with open_project(project, "a") as p, p.transaction():
        p.add_experiment(name, raw, sampling_rate=fs, systeminfo=Systeminfo(channels), excitation=excitation,
                         source=uff_path.name, channel_names=names)
        if frfs:
            _store_frfs(p, name, frfs, uff_path)
    stored = f"{len(records)} time record{'s' * (len(records) > 1)} as experiment {name!r}"
    return stored + (f", {len(frfs)} FRFs" if frfs else ""), notes


def _record_units(uff_path: Path, records: list[UffFunction], table: dict, unspecified: tuple[str, ...],
                  listed: str) -> list[tuple[SensorType, float]]:
    """Each record's (sensor type, V per SI unit) from its ordinate units label: in ``table``, or
    without a sensor when ``unspecified``; another label is refused naming its dataset (a unit of
    another scale, 'mg' or 'kN', stored at scale 1 would be read 1000 times off)."""
    out = []
    for f in records:
        key = unit_key(f.unit)
        if key not in table and key not in unspecified:
            raise ConfigError(f"{uff_path}: dataset {f.dataset} (58 {f.name!r}) record 9 field 6 (ordinate units "
                              f"label): {f.unit!r} is not one of {listed}")
        out.append(table.get(key, (SensorType.NONE, 1.0)))
    return out


#: Dataset 58 record 7 holds the sampling interval with 6 significant digits (E13.5), so 1/5120 s
#: reads back as 1.95312e-4 s: a whole number of hertz within that rounding is the rate written
HEADER_DIGITS_REL = 5e-6


def _sampling_rate(dt: float) -> float:
    whole = round(1.0 / dt)
    return float(whole) if whole > 0 and abs(1.0 / whole - dt) <= HEADER_DIGITS_REL * dt else 1.0 / dt


def _reference_index(records: list[UffFunction], names: list[str], where: str) -> int | None:
    """The record at the node and direction the other records name as their reference (the
    hammer's), when there is one."""
    refs = {(f.ref_node, f.ref_dir) for f in records if f.ref_node > 0}
    hits = [k for k, f in enumerate(records) if f.rsp_node > 0 and (f.rsp_node, f.rsp_dir) in refs]
    if len(hits) > 1:
        raise ConfigError(f"{where}: records {', '.join(repr(names[k]) for k in hits)} are all at the reference "
                          "node and direction: cannot tell the force record; give --force-channel")
    return hits[0] if hits else None


def _rig_mapping(rig: Rig, records: list[UffFunction], fidx: int | None, where: str, names: list[str],
                 strict: bool = True) -> dict[int, tuple[int, float]]:
    """Record index -> (rig channel, sign) by UFF node and direction: a record at a sensor's node
    (its ``uff_node``, else the number export-uff gives it) along the sensor's direction, or against
    it (sign -1). Empty when no response record is at a sensor's node and direction. ``strict``:
    then every response record must match one sensor, and no sensor two records."""
    at = rig_nodes(rig)[2]
    sensor_at = {v: ch for ch, v in at.items()} | {(n, -d): ch for ch, (n, d) in at.items()}
    out: dict[int, tuple[int, float]] = {}
    for k, f in enumerate(records):
        if k != fidx and (f.rsp_node, f.rsp_dir) in sensor_at and f.rsp_dir != 0:
            out[k] = (sensor_at[(f.rsp_node, f.rsp_dir)], 1.0 if (f.rsp_node, f.rsp_dir) in at.values() else -1.0)
    if not out or not strict:
        return out
    for k, f in enumerate(records):
        # node 0, direction 0: a channel without a sensor (export-uff writes a rig's spare channels so)
        if k != fidx and k not in out and (f.rsp_node, f.rsp_dir) != (0, 0):
            raise ConfigError(f"{where}: time record {names[k]!r} at UFF node {f.rsp_node} direction {f.rsp_dir:+d} "
                              f"matches no sensor of rig {rig.name!r} (sensor nodes: "
                              f"{', '.join(str(n) for n in sorted({n for n, _ in at.values()}))})")
    first: dict[int, int] = {}
    for k, (ch, _) in out.items():
        if ch in first:
            f = records[k]
            raise ConfigError(f"{where}: time records {names[first[ch]]!r} and {names[k]!r} (UFF node {f.rsp_node} "
                              f"direction {f.rsp_dir:+d}) both match sensor {rig.sensor_on_channel(ch).name!r} "
                              f"of rig {rig.name!r}")
        first[ch] = k
    if fidx is not None:
        if rig.force_channel is None:
            raise ConfigError(f"{where}: rig {rig.name!r} has no force channel for record {names[fidx]!r}")
        out[fidx] = (rig.force_channel, 1.0)
    return out


def _import_onto_rig(project, rig: Rig, uff_path: Path, name: str, content, records: list[UffFunction],
                     frfs: list[UffFunction], names: list[str], fidx: int | None, fs: float,
                     notes: tuple[str, ...], hammer: tuple):
    """Time records laid onto the rig's channels: by UFF node and direction, else by record name,
    else in order (said in a note); volts through the rig's sensitivities (``rig_import``)."""
    where = str(uff_path)
    point, direction, force_body = hammer
    by_node = _rig_mapping(rig, records, fidx, where, names)
    signs, by_name = np.ones(len(records)), False
    if by_node:
        mapping = {k: ch for k, (ch, _) in by_node.items()}
        signs = np.array([by_node[k][1] if k in by_node else 1.0 for k in range(len(records))])
    else:
        mapping, by_name = columns_to_channels(rig, names, where, None if fidx is None else names[fidx],
                                               "time record")
        if not by_name:
            notes += (f"{where}: no record carries a sensor's UFF node or name: records taken as the "
                      f"channels 0-{rig.channel_count - 1} of rig {rig.name!r} in order",)
    if fidx is not None and (point is None or direction is None):  # the hammer's node in the file, if there
        hit = _node_point(content.geometry, records[fidx].rsp_node, records[fidx].rsp_dir)
        if hit is not None:
            point = hit[0] if point is None else point
            direction = hit[1] if direction is None else direction
    # the labels onto_rig reads (an empty one as volts), another refused naming its dataset
    _record_units(uff_path, [records[k] for k in sorted(mapping)], UNITS, ("",), "m/s^2, g, N or V (on a rig)")
    data = np.column_stack([f.data for f in records]).astype(float) * signs
    rec = onto_rig(rig, names, [f.unit for f in records], data, fs, where, point, direction,
                   force_body=force_body, mapping=mapping, what="time record")
    with open_project(project, "a") as p, p.transaction():
        p.add_experiment(name, rec.raw, sampling_rate=fs, systeminfo=rec.systeminfo,
                         excitation=rec.excitation, source=uff_path.name, channel_names=rec.channel_names)
        if frfs:
            _store_frfs(p, name, frfs, uff_path)
    how = "UFF node" if by_node else "name" if by_name else "order"
    stored = (f"{len(records)} time record{'s' * (len(records) > 1)} onto rig {rig.name!r} (by {how}) "
              f"as experiment {name!r}")
    return stored + (f", {len(frfs)} FRFs" if frfs else ""), notes + rec.notes


def _store_frfs(p: Project, name: str, frfs: list[UffFunction], uff_path: Path) -> None:
    arrays, attrs = _frf_arrays(frfs, str(uff_path))
    p.write_derived(name, "frf", arrays,
                    provenance={"plugin": "odsuite.uff", "version": __version__, "parameters": {"source": uff_path.name},
                                "inputs": [p.experiment(name).object_id]},
                    attrs=attrs)


def _direction_code(axis: np.ndarray) -> int:
    """+-1, +-2, +-3 when ``axis`` is a global axis, else 0 (needs a local system)."""
    k = int(np.argmax(np.abs(axis)))
    return int(np.sign(axis[k])) * (k + 1) if np.isclose(abs(axis[k]), 1.0) else 0


def _local_system(axis: np.ndarray) -> np.ndarray:
    """Rotation whose x column is ``axis`` (a sensor's measuring direction)."""
    ex = axis / np.linalg.norm(axis)
    helper = np.eye(3)[int(np.argmin(np.abs(ex)))]
    ez = np.cross(ex, helper)
    ez /= np.linalg.norm(ez)
    return np.column_stack([ex, np.cross(ez, ex), ez])


class _Nodes:
    """Nodes of an export: one node per location (a triaxial sensor's three channels share it),
    direction codes in the node's displacement system (a local one, made from the first
    direction, when a direction is not a global axis; a direction that fits neither gets a node of
    its own at the same place)."""

    #: points closer than this (m) are one location: far below any sensor's size
    SAME_PLACE_M = 1e-9

    def __init__(self, reserved: set[int] = frozenset()) -> None:
        self.nums: list[int] = []
        self.xyz: list[np.ndarray] = []
        self.disp_cs: list[int] = []
        self.directed: list[bool] = []
        self.rotation: dict[int, np.ndarray] = {}
        self.reserved = set(reserved)  # numbers the rig's sensors declare (uff_node): not given to others

    def _local(self, axis: np.ndarray) -> int:
        cs = len(self.rotation) + 1
        self.rotation[cs] = _local_system(axis)
        return cs

    def add(self, point: np.ndarray, axis: np.ndarray | None = None, number: int | None = None) -> tuple[int, int]:
        """The node (its number) and direction code of ``point`` along ``axis``; ``number``: the
        node number the sensor declares (its place must then be the node's)."""
        p = np.asarray(point, dtype=float)
        a = None if axis is None else np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        for i, q in enumerate(self.xyz):
            same_place = np.allclose(q, p, rtol=0, atol=self.SAME_PLACE_M)
            if number is not None and self.nums[i] == number and not same_place:
                mm = ", ".join(f"{1e3 * v:g}" for v in q)
                raise ConfigError(f"UFF node {number} is declared (uff_node) at two places, one of them ({mm}) mm")
            if not same_place or (number is not None and self.nums[i] != number):
                continue
            if a is None:
                return self.nums[i], 0
            R = self.rotation.get(self.disp_cs[i], np.eye(3))
            if code := _direction_code(R.T @ a):
                self.directed[i] = True
                return self.nums[i], code
            if not self.directed[i] and self.disp_cs[i] == 0:
                self.disp_cs[i], self.directed[i] = self._local(a), True
                return self.nums[i], 1
        code, cs = 0, 0
        if a is not None:
            code = _direction_code(a)
            if code == 0:
                cs, code = self._local(a), 1
        if number is None:
            number = len(self.nums) + 1
            while number in self.reserved or number in self.nums:
                number += 1
        self.nums.append(number)
        self.xyz.append(p)
        self.disp_cs.append(cs)
        self.directed.append(a is not None)
        return number, code

    def geometry(self, traces: list[tuple[str, list[int]]]) -> UffGeometry:
        return UffGeometry(node_nums=np.array(self.nums, dtype=int), xyz=np.array(self.xyz),
                           disp_cs=np.array(self.disp_cs, dtype=int), cs_rotation=self.rotation,
                           cs_origin={c: np.zeros(3) for c in self.rotation}, trace_lines=traces)


def rig_nodes(rig: Rig, n_channels: int | None = None) -> tuple[_Nodes, list[tuple[str, list[int]]],
                                                                    dict[int, tuple[int, int]]]:
    """The UFF nodes of a rig as export-uff writes them and import-uff reads them: each plate's top
    corners, then each body's sensors (on channels below ``n_channels``) with their node number
    (the sensor's ``uff_node``, else the next free one) and direction code; the trace lines; and
    per channel its (node, direction code)."""
    n_channels = rig.channel_count if n_channels is None else n_channels
    nodes = _Nodes({s.uff_node for s in rig.sensors if s.uff_node is not None})
    traces: list[tuple[str, list[int]]] = []
    at: dict[int, tuple[int, int]] = {}
    for body in rig.bodies:
        if body.plate is not None:
            corners = plate_corners(body.plate)[[list(CORNERS).index(c) for c in _TOP_FACE]]
            ids = [nodes.add(c)[0] for c in corners]
            traces.append((f"{body.name} plate", ids + ids[:1]))
        sensors = [s for s in rig.sensors if s.body == body.name and s.channel < n_channels]
        for s in sensors:
            try:
                at[s.channel] = nodes.add(s.position, np.asarray(s.axis, dtype=float), s.uff_node)
            except ConfigError as exc:
                raise ConfigError(f"rig {rig.name!r}: sensor {s.name!r}: {exc}") from None
            twin = next((c for c, v in at.items() if c != s.channel and v[0] == at[s.channel][0]
                         and abs(v[1]) == abs(at[s.channel][1])), None)
            if twin is not None:
                raise ConfigError(f"rig {rig.name!r}: sensors {rig.sensor_on_channel(twin).name!r} and {s.name!r} "
                                  f"measure along one line at UFF node {at[s.channel][0]}: a UFF record cannot "
                                  "tell them apart (give one of them another uff_node)")
        if len(sensors) > 1:
            traces.append((f"{body.name} sensors", list(dict.fromkeys(at[s.channel][0] for s in sensors))))
    return nodes, traces, at


def export_uff(project: str | Path, out: str | Path, experiment: str | None = None, *, binary: bool = True,
               node_dataset: int = 15) -> Path:
    """Write an experiment (default: the only one) as UFF: its channels in SI units as time records,
    its derived "frf" when present, and with a rig the nodes (plate top corners, sensors, hammer
    point; metres, rig frame) and trace lines of each plate outline and each body's sensors."""
    out = Path(out)
    with open_project(project) as p:
        names = p.experiment_names()
        if experiment is None:
            if len(names) != 1:
                raise ConfigError(f"{p.path}: name the experiment to export (experiments: {', '.join(names) or 'none'})")
            experiment = names[0]
        exp = p.experiment(experiment)
        rig = p.rig
        frf = p.read_derived(experiment, "frf") if "frf" in p.derived_kinds(experiment) else None
        frf_outputs = json.loads(p.derived_info(experiment, "frf")["attrs"]["outputs"]) if frf else []
        data = physical(exp)
    nodes, traces, at = rig_nodes(rig, exp.n_channels) if rig is not None else (_Nodes(), [], {})
    if rig is not None and exp.excitation is not None:
        at[exp.excitation.force_channel] = nodes.add(exp.excitation.point, exp.excitation.direction)
    functions = [time_function(exp.channel_names[k], data[:, k], 1.0 / exp.sampling_rate,
                               exp.systeminfo.channels[k].unit, node=at.get(k, (0, 0))[0],
                               direction=at.get(k, (0, 0))[1]) for k in range(exp.n_channels)]
    if frf is not None:
        ref = at.get(exp.excitation.force_channel, (0, 0)) if exp.excitation else (0, 0)
        H = frf["H_real"] + 1j * frf["H_imag"]
        for row, out_name in enumerate(frf_outputs):
            k = exp.channel_names.index(out_name) if out_name in exp.channel_names else -1
            rsp = at.get(k, (0, 0))
            functions.append(UffFunction(f"H {out_name}", FUNC_FRF, frf["frequency"], H[row],
                                         f"{exp.systeminfo.channels[k].unit}/N" if k >= 0 else "", "Hz",
                                         rsp[0], rsp[1], ref[0], ref[1], description=experiment))
    geometry = nodes.geometry(traces) if nodes.xyz else None
    if out.exists():  # as write_uff: an export never overwrites
        raise ConfigError(f"{out}: file exists; refusing to overwrite")
    # doubles in binary 58b, about 20 characters a value in ASCII (the header lines are in the reserve)
    needed = sum(f.x.size + f.data.size * (2 if np.iscomplexobj(f.data) else 1) for f in functions) * \
        (8 if binary else 20)
    write_output(out, needed, lambda tmp: write_uff(tmp, functions=functions, geometry=geometry, binary=binary,
                                                    node_dataset=node_dataset))
    return out
