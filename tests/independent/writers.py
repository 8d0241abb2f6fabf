"""File writers for simulated records: LabVIEW .lvm, the thesis's .DAT + .CTR pair, UFF 58 time
records (pyuff), a JSON truth file and a rig TOML in the multi-body format of the rig-format issue.
Each writes the format from its description, not through odsuite's own writers."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .rigsim import Record
from .rigs import RigBundle
from .structure import Daq, mat3

LVM_DATE, LVM_TIME = "2026/01/15", "10:30:00,000000"  # fixed: files are reproducible byte for byte


def _lvm_number(value: float, decimal: str) -> str:
    text = f"{value:.10g}"
    return text.replace(".", decimal) if decimal != "." else text


def write_lvm(path: str | Path, record: Record, *, decimal: str = ".", physical: bool = False,
              x_columns: str = "One") -> Path:
    """A LabVIEW Measurement file (Writer_Version 2, tab-separated, one segment). ``physical``:
    values divided by each channel's nominal volts-per-unit and the unit in Y_Unit_Label;
    otherwise volts. ``x_columns``: "One" (a shared time column), "No" or "Multi"."""
    if decimal not in (".", ","):
        raise ValueError(f"decimal separator {decimal!r}: expected '.' or ','")
    if x_columns not in ("One", "No", "Multi"):
        raise ValueError(f"x_columns {x_columns!r}: expected 'One', 'No' or 'Multi'")
    values = record.volts / record.scale if physical else record.volts
    units = record.units if physical else ["V"] * len(record.names)
    n_ch, n = len(record.names), record.time.size
    dt = record.time[1] - record.time[0]
    lines = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab",
             f"Decimal_Separator\t{decimal}", "Multi_Headings\tNo", f"X_Columns\t{x_columns}",
             "Time_Pref\tRelative", "Operator\tgenerator", f"Date\t{LVM_DATE}", f"Time\t{LVM_TIME}",
             "***End_of_Header***\t", "\t"]
    # Multi puts an empty cell over every time column in the channel header
    per = (lambda cells: "\t".join(f"{c}\t" for c in cells)) if x_columns == "Multi" else "\t".join

    def number(v):
        return _lvm_number(v, decimal)

    lines += [
        f"Channels\t{n_ch}",
        f"Samples\t{per([str(n)] * n_ch)}",
        f"Date\t{per([LVM_DATE] * n_ch)}",
        f"Time\t{per([LVM_TIME] * n_ch)}",
        f"Y_Unit_Label\t{per(units)}",
        f"X_Dimension\t{per(['Time'] * n_ch)}",
        f"X0\t{per([number(0.0)] * n_ch)}",
        f"Delta_X\t{per([f'{dt:.15E}'.replace('.', decimal)] * n_ch)}",
        "***End_of_Header***\t",
    ]
    if x_columns == "Multi":
        lines.append("\t".join(f"X_Value\t{name}" for name in record.names) + "\tComment")
    else:
        lines.append("X_Value\t" + "\t".join(record.names) + "\tComment")
    times = [number(t) for t in record.time]
    for i in range(n):
        row = [number(v) for v in values[i]]
        if x_columns == "One":
            lines.append(times[i] + "\t" + "\t".join(row))
        elif x_columns == "No":
            lines.append("\t" + "\t".join(row))
        else:
            lines.append("\t".join(f"{times[i]}\t{v}" for v in row))
    path = Path(path)
    path.write_text("\r\n".join(lines) + "\r\n", encoding="latin-1")  # LabVIEW on Windows: CRLF, ANSI
    return path


def write_dat(path: str | Path, record: Record) -> Path:
    """The thesis's .DAT: samples x channels of volts, tab-separated, every value repr-exact."""
    path = Path(path)
    path.write_text("".join("\t".join(repr(float(v)) for v in row) + "\n" for row in record.volts),
                    encoding="utf-8")
    return path


_SENSOR_TYPE = {"m/s^2": 4, "N": 1, "V": 3}  # Table E.2 row 0: accelerometer, load cell, voltage


def _milli(value: float) -> str:
    return f"{value * 1000:.12g}"


def write_ctr(path: str | Path, record: Record, rig: RigBundle, daq: Daq) -> Path:
    """The thesis's .CTR Systeminfo (Table E.2: 34 rows x one column per channel, tab-separated):
    mV per unit, DAQ gain, the thesis's processing chain (double integration around 8th-order
    elliptic 20 Hz high-pass filters for accelerometers), offset over the pre-trigger samples."""
    serials = {a.name: a.serial for a in rig.accelerometers} | {rig.force_sensor.name: rig.force_sensor.serial}
    cols = []
    for k, (name, unit) in enumerate(zip(record.names, record.units)):
        accel = unit == "m/s^2"
        per_unit = abs(record.scale[k]) / daq.amplifier_gain  # V per unit at the sensor
        cols.append([
            str(_SENSOR_TYPE[unit]), name, serials.get(name) or "-", _milli(per_unit),
            "1" if accel else "0",  # row 4 integration: double for accelerometers
            "1", "8" if accel else "0", f"{daq.sampling_rate:g}",  # rows 5-7: high-pass, order, rate
            f"{daq.sampling_rate / 2:g}", "20",  # rows 8-9: cut-offs (the high one unused by a high-pass)
            "0.1", "60", "3" if accel else "0", "0",  # rows 10-13: ripple, attenuation, filters 1+2, micro
            "1" if record.scale[k] < 0 else "0",  # row 14 invert
            "0", str(daq.pre_trigger), f"{daq.amplifier_gain:g}", "0",  # rows 15-18
            f"{daq.adc_range[1]:g}", f"{daq.adc_range[0]:g}",  # rows 19-20 limits
        ])
    n = len(cols)
    rows = [[c[r] for c in cols] for r in range(21)]
    nine = next((b.nine_sensor_set for b in rig.structure.bodies if b.nine_sensor_set), None)
    plates = [b.plate["size"] for b in rig.structure.bodies if b.plate]

    def rig_row(cells):
        cells = list(cells)[:n]
        return cells + ["-"] * (n - len(cells))

    rows.append(rig_row(["1", "1"] if nine else ["0", "0"]))  # 21: use in GCC / AG
    for i in range(3):  # 22-24 plate sizes, mm
        rows.append(rig_row([_milli(p[i]) for p in plates[:3]]))
    rows += [rig_row([]) for _ in range(3)]  # 25-27 plate origins: not given
    rows.append(rig_row(["0"]))  # 28 plot from the reference origin
    rows.append(rig_row([]))  # 29 coordinate columns
    if nine:
        rows += [rig_row([_milli(nine[key])]) for key in ("rx", "ry", "rz")]
        roles = ("xC", "yC", "zC", "x1", "z1", "y2", "z2", "x3", "y3")
        rows.append(rig_row([str(record.names.index(nine["sensors"][r])) for r in roles]))
    else:
        rows += [rig_row([]) for _ in range(4)]
    path = Path(path)
    path.write_text("".join("\t".join(r) + "\n" for r in rows), encoding="utf-8")
    return path


def write_uff58(path: str | Path, record: Record, rig: RigBundle, *, binary: bool = True) -> Path:
    """One UFF dataset 58 (time record, function type 1) per channel in physical units. Nodes
    number the distinct sensor positions (the load cell: node 0 = unspecified); the direction is
    +-1..3 when the nominal axis lies along a rig axis, else 0."""
    import pyuff

    positions: list[tuple] = []
    sets = []
    sensors = {a.name: a for a in rig.accelerometers}
    values = record.volts / record.scale
    dt = float(record.time[1] - record.time[0])
    for k, name in enumerate(record.names):
        node, direction = 0, 0
        if name in sensors:
            a = sensors[name]
            key = tuple(np.round(a.position, 9))
            if key not in positions:
                positions.append(key)
            node = positions.index(key) + 1
            axis = np.asarray(a.axis, float)
            j = int(np.argmax(np.abs(axis)))
            if abs(abs(axis[j]) - 1.0) < 1e-9:
                direction = int(np.sign(axis[j])) * (j + 1)
        data = np.ascontiguousarray(values[:, k])
        sets.append(pyuff.prepare_58(
            binary=int(binary), id1=name, id2=f"channel {k}", id3="NONE", id4="NONE", id5="NONE",
            func_type=1, ver_num=0, load_case_id=0, rsp_ent_name="NONE", rsp_node=node, rsp_dir=direction,
            ref_ent_name="NONE", ref_node=0, ref_dir=0, ord_data_type=4, num_pts=data.size,
            abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=dt, z_axis_value=0.0,
            abscissa_spec_data_type=17, abscissa_len_unit_exp=0, abscissa_force_unit_exp=0,
            abscissa_temp_unit_exp=0, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=12 if record.units[k] == "m/s^2" else 13 if record.units[k] == "N" else 0,
            ordinate_len_unit_exp=0, ordinate_force_unit_exp=0, ordinate_temp_unit_exp=0,
            ordinate_axis_units_lab=record.units[k], orddenom_spec_data_type=0, orddenom_len_unit_exp=0,
            orddenom_force_unit_exp=0, orddenom_temp_unit_exp=0, orddenom_axis_units_lab="NONE",
            z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0,
            z_axis_axis_units_lab="NONE", data=data, x=record.time.copy(), return_full_dict=True,
        ))
    path = Path(path)
    path.write_bytes(b"")  # pyuff appends: start from an empty file
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    return path


def to_jsonable(value):
    """numpy arrays and scalars as lists and numbers; callables (mode shapes) left out."""
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items() if not callable(v)}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_truth(path: str | Path, truth: dict) -> Path:
    path = Path(path)
    path.write_text(json.dumps(to_jsonable(truth), indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return path


# ---------------------------------------------------------------------------------------------
# rig TOML. A small emitter of our own: the files need only tables, arrays of tables and inline
# values, and a test helper should not add a TOML-writing dependency to the project.


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            raise ValueError(f"TOML cannot hold {value!r}")
        return repr(float(value))
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, np.ndarray):
        return _toml_value(value.tolist())
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def _key(key: str) -> str:
    return key if key.replace("_", "").replace("-", "").isalnum() else json.dumps(key)


def _table(lines: list[str], header: str, table: dict) -> None:
    lines.append("")
    lines.append(header)
    for k, v in table.items():
        if not isinstance(v, dict):
            lines.append(f"{_key(k)} = {_toml_value(v)}")
    for k, v in table.items():
        if isinstance(v, dict):
            _table(lines, f"[{header.strip('[]')}.{k}]", v)


def dumps_toml(data: dict) -> str:
    """Top-level scalars, then tables and arrays of tables (sub-tables of their entries allowed)."""
    lines: list[str] = []
    for k, v in data.items():
        if not isinstance(v, dict) and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            lines.append(f"{_key(k)} = {_toml_value(v)}")
    for k, v in data.items():
        if isinstance(v, dict):
            _table(lines, f"[{k}]", v)
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for entry in v:
                _table(lines, f"[[{k}]]", entry)
    return "\n".join(lines).lstrip("\n") + "\n"


def _matrix_or_diagonal(value) -> list:
    m = mat3(value)
    return np.diag(m).tolist() if np.allclose(m, np.diag(np.diag(m))) else m.tolist()


def rig_document(rig: RigBundle) -> dict:
    """The rig in the multi-body rig format: [[bodies]], [[springs]], [[sensors]] (single-axis,
    triaxial and force) and [acquisition]."""
    bodies = []
    for b in rig.structure.bodies:
        entry = {"name": b.name, "mass": float(b.mass), "com": list(map(float, b.com)),
                 "inertia": np.asarray(b.inertia, float).tolist()}
        if b.plate:
            entry["plate"] = dict(b.plate)
        if b.nine_sensor_set:
            entry["nine_sensor_set"] = dict(b.nine_sensor_set)
        bodies.append(entry)
    springs = [{"name": s.name, "body": s.body, "other": s.other, "position": list(map(float, s.position)),
                "stiffness": _matrix_or_diagonal(s.stiffness), "damping": _matrix_or_diagonal(s.damping)}
               for s in rig.structure.springs]
    sensors = []
    done = set()
    for a in rig.accelerometers:
        if a.triaxial is None:
            entry = {"name": a.name, "kind": "accelerometer", "channel": a.channel, "body": a.body,
                     "position": list(map(float, a.position)), "axis": list(map(float, a.axis)),
                     "sign": int(a.sign), "sensitivity": a.sensitivity}
            if a.serial:
                entry["serial"] = a.serial
            sensors.append(entry)
        elif a.triaxial not in done:
            done.add(a.triaxial)
            axes = [x for x in rig.accelerometers if x.triaxial == a.triaxial]
            signs = [int(x.sign) for x in axes]
            sensors.append({
                "name": a.triaxial, "kind": "triaxial_accelerometer", "body": a.body,
                "position": list(map(float, a.position)), "channels": [x.channel for x in axes],
                "axes": [list(map(float, x.axis)) for x in axes],
                "sensitivity": [x.sensitivity for x in axes],
                "sign": signs[0] if len(set(signs)) == 1 else signs,
            })
    f = rig.force_sensor
    sensors.append({"name": f.name, "kind": "force", "channel": f.channel, "sensitivity": f.sensitivity,
                    "sign": int(f.sign)})
    d = rig.daq
    acquisition = {"sampling_rate": d.sampling_rate, "pre_trigger": d.pre_trigger,
                   "adc_range": list(d.adc_range), "adc_bits": d.adc_bits or 0}
    if d.aa_family is not None:
        acquisition["anti_aliasing"] = {"family": {"butter": "butterworth", "ellip": "elliptic"}[d.aa_family],
                                        "order": d.aa_order, "cutoff_hz": d.aa_cutoff_hz}
    corners = {a.iepe_corner_hz for a in rig.accelerometers if a.iepe_corner_hz is not None}
    if corners:
        acquisition["iepe_corner_hz"] = min(corners)
    channels = [a.channel for a in rig.accelerometers] + [f.channel]
    doc = {"name": rig.name, "description": rig.description, "frame": rig.frame,
           "default_model": "rigid-bodies", "force_channel": f.channel, "channel_count": max(channels) + 1,
           "bodies": bodies, "springs": springs, "sensors": sensors, "acquisition": acquisition}
    if rig.processing:
        doc["processing"] = dict(rig.processing)
    return doc


def write_rig_toml(path: str | Path, rig: RigBundle) -> Path:
    path = Path(path)
    path.write_text(dumps_toml(rig_document(rig)), encoding="utf-8")
    return path
