"""Record lengths and counts of a UFF file, checked on its raw text before pyuff reads it, and the
parsed sets checked against their own headers after: pyuff reads what it finds, so a file cut off,
a line lost or doubled, or a count changed would otherwise import as fewer or shifted values.

Each function raises ConfigError naming the file, the dataset (its number in the file and type) and
the line. UFF has no checksum: a changed digit inside a number stays a number and is not found.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from odsuite.api import ConfigError

DELIMITER = b"    -1"
#: values per data line of ASCII dataset 58 by ordinate data type (2 real single, 4 real double,
#: 5 complex single, 6 complex double; file format manual)
_58_VALUES_PER_LINE = {2: 6, 4: 4, 5: 6, 6: 4}
#: header lines of a dataset 58 after its type line
_58_HEADER_LINES = 11


def _is_delimiter(line: bytes) -> bool:
    return line.strip() == b"-1"


def split_datasets(path: Path, raw: bytes) -> list[tuple[int, list[bytes], int]]:
    """The datasets of ``raw``: (type, text lines after the type line, line number of the type
    line). Every dataset must be closed by its ``-1`` line and the file must end after the last
    one; binary 58b data are skipped by their byte count."""
    lines = raw.split(b"\n")
    out: list[tuple[int, list[bytes], int]] = []
    pos = 0  # byte offset of line i
    i = 0
    n = len(lines)
    while i < n:
        if not lines[i].strip():
            pos += len(lines[i]) + 1
            i += 1
            continue
        if not _is_delimiter(lines[i]):
            if not out:
                raise ConfigError(f"{path}: no UFF datasets found (not a UFF file, or cut short)")
            raise ConfigError(f"{path}: line {i + 1}: expected a dataset start '-1', found {_show(lines[i])}")
        if i + 1 >= n or not lines[i + 1].strip():
            raise ConfigError(f"{path}: line {i + 2}: dataset {len(out) + 1} has no type line (cut off?)")
        head = lines[i + 1].split()
        kind = head[0].decode("ascii", "replace")
        start = i + 1
        pos += len(lines[i]) + 1 + len(lines[i + 1]) + 1
        i += 2
        body: list[bytes] = []
        if kind == "58b":
            i, pos, body = _binary_58(path, len(out) + 1, head, lines, raw, i, pos, start)
            out.append((58, body, start + 1))
            continue
        try:
            number = int(kind)
        except ValueError:
            number = 0
        if number < 1:  # also a doubled or lost '-1' line, which shifts every dataset after it
            raise ConfigError(f"{path}: line {start + 1}: dataset type {kind!r} is not a dataset number") from None
        while i < n and not _is_delimiter(lines[i]):
            body.append(lines[i])
            pos += len(lines[i]) + 1
            i += 1
        if i >= n:
            raise ConfigError(f"{path}: dataset {len(out) + 1} (type {number}) from line {start + 1} has no closing "
                              "'-1' line (cut off?)")
        pos += len(lines[i]) + 1
        i += 1
        out.append((number, body, start + 1))
    if not out:
        raise ConfigError(f"{path}: no UFF datasets found (not a UFF file, or cut short)")
    return out


def _binary_58(path, index, head, lines, raw, i, pos, start):
    """Skip a binary 58b dataset: its header lines, then its data, which the closing '-1' line must
    follow right after the byte count of its type line or the length its record 7 implies."""
    try:
        header_lines, byte_count = int(head[3]), int(head[4])
    except (IndexError, ValueError):
        raise ConfigError(f"{path}: line {start + 1}: dataset {index} (58b) type line lacks its line and byte "
                          f"counts: {_show(lines[start])}") from None
    if header_lines != _58_HEADER_LINES or i + header_lines > len(lines):
        raise ConfigError(f"{path}: line {start + 1}: dataset {index} (58b) says {header_lines} header lines, "
                          f"expected {_58_HEADER_LINES}")
    body = lines[i:i + header_lines]
    for line in body:
        pos += len(line) + 1
    # pyuff writes the byte count of real values for complex ones too: the length record 7 implies
    # (points, values per point, bytes per value) is taken as well
    lengths = [byte_count, *_58b_implied_bytes(body[6])]
    for length in lengths:
        rest = raw[pos + length:]
        if len(raw) - pos >= length and rest.lstrip(b"\r\n").startswith(DELIMITER):
            break
    else:
        if len(raw) - pos < min(lengths):
            raise ConfigError(f"{path}: dataset {index} (58b) from line {start + 1}: {len(raw) - pos} of its "
                              f"{byte_count} data bytes (cut off?)")
        raise ConfigError(f"{path}: dataset {index} (58b) from line {start + 1}: its {byte_count} data bytes are "
                          "not followed by the closing '-1' line (byte count wrong?)")
    data = raw[pos:pos + length]
    stripped = rest.lstrip(b"\r\n")
    pos += length + (len(rest) - len(stripped))
    # continue with the line after the closing delimiter
    tail = raw[pos:].split(b"\n", 1)
    consumed = raw.count(b"\n", 0, pos + len(tail[0]) + 1)
    return consumed, pos + len(tail[0]) + 1, body + [b"<binary>"] + [data]


def _58b_implied_bytes(record7: bytes) -> list[int]:
    """The data bytes record 7 of a 58b dataset implies (none when it cannot be read)."""
    try:
        ord_type, num_pts, even = (int(t) for t in record7.split()[:3])
    except ValueError:
        return []
    if ord_type not in _58_VALUES_PER_LINE:
        return []
    per_point = (1 if ord_type in (2, 4) else 2) + (0 if even else 1)
    return [num_pts * per_point * (4 if ord_type in (2, 5) else 8)]


def check_ascii_58(path: Path, index: int, body: list[bytes], line0: int) -> None:
    """An ASCII dataset 58: as many values as its header's point count, in full lines of the fixed
    width its data type gives."""
    if len(body) < _58_HEADER_LINES:
        raise ConfigError(f"{path}: dataset {index} (58) from line {line0}: {len(body)} header lines, "
                          f"expected {_58_HEADER_LINES}")
    rec7 = body[6].split()
    try:
        ord_type, num_pts, even = int(rec7[0]), int(rec7[1]), int(rec7[2])
    except (IndexError, ValueError):
        raise ConfigError(f"{path}: line {line0 + 7}: dataset {index} (58) record 7 is not 'type points spacing ...': "
                          f"{_show(body[6])}") from None
    if ord_type not in _58_VALUES_PER_LINE or num_pts < 1 or even not in (0, 1):
        raise ConfigError(f"{path}: line {line0 + 7}: dataset {index} (58) record 7 has data type {ord_type}, "
                          f"{num_pts} points, spacing {even}")
    per_line = _58_VALUES_PER_LINE[ord_type]
    per_point = (1 if ord_type in (2, 4) else 2) + (0 if even else 1)
    expected = num_pts * per_point
    data = body[_58_HEADER_LINES:]
    found = 0
    for k, line in enumerate(data):
        text = line.rstrip()  # writers pad lines with blanks to 80 characters
        cells = len(text.split())
        full = k < len(data) - 1
        # widths differ between writers (E13.5, E12.5 and a blank, 4E20.12): values are counted
        if even and ((full and cells != per_line) or not 0 < cells <= per_line):
            raise ConfigError(f"{path}: line {line0 + _58_HEADER_LINES + k + 1}: dataset {index} (58) data line "
                              f"has {cells} values, expected {per_line if full else f'1 to {per_line}'}")
        found += cells
    if found != expected:
        each = f" of {per_point} values" if per_point > 1 else ""
        raise ConfigError(f"{path}: dataset {index} (58) from line {line0}: {found} values, but its record 7 says "
                          f"{num_pts} points{each} (a line lost or doubled, or the count changed?)")


#: integer columns of dataset 58 record 6 (format 2(I5,I10),2(1X,10A1,I10,I4)): function type,
#: function id, version, load case, response node and direction, reference node and direction
_58_RECORD6_INTS = ((0, 5), (5, 15), (15, 20), (20, 30), (41, 51), (51, 55), (66, 76), (76, 80))


def check_record6(path: Path, index: int, body: list[bytes], line0: int) -> None:
    """Dataset 58 record 6 (nodes and directions): every integer column holds an integer or blanks
    (pyuff reads anything else there as 0, a node or direction that was never in the file)."""
    if len(body) < 6:
        return  # check_ascii_58 / the 58b header count report a short header
    line = body[5].rstrip(b"\r\n")
    for a, b in _58_RECORD6_INTS:
        cell = line[a:b].strip()
        if cell and not cell.lstrip(b"+-").isdigit():
            raise ConfigError(f"{path}: line {line0 + 6}: dataset {index} (58) record 6 columns {a + 1}-{b}: "
                              f"not an integer: {_show(line[a:b])}")


def check_structure(path: Path, raw: bytes) -> list[int]:
    """Every dataset closed, the file complete, ASCII 58 data of the length their headers give;
    returns the dataset types in file order."""
    last = raw.rsplit(b"\n", 1)[-1]
    if last and not last.strip():  # blanks after the last line end: cut inside a line
        raise ConfigError(f"{path}: the file ends inside a line of blanks (cut off?)")
    datasets = split_datasets(path, raw)
    for index, (kind, body, line0) in enumerate(datasets, start=1):
        if kind == 58:
            check_record6(path, index, body, line0)
        if kind == 58 and (not body or body[-2:-1] != [b"<binary>"]):
            check_ascii_58(path, index, body, line0)
    return [kind for kind, _, _ in datasets]


def check_types(path: Path, types: list[int], sets: list[dict]) -> None:
    """pyuff found the datasets the type lines announce (a lost or doubled line can make it skip
    or merge one)."""
    read = [int(s.get("type", 0)) for s in sets]
    if read != types:
        k = next((i for i, (a, b) in enumerate(zip(types, read)) if a != b), min(len(types), len(read)))
        said = types[k] if k < len(types) else "none"
        got = read[k] if k < len(read) else "none"
        raise ConfigError(f"{path}: dataset {k + 1}: its type line says {said}, its contents read as {got}")


def check_function(path: Path, index: int, s: dict) -> None:
    """A parsed dataset 58: abscissa and ordinate as long as its point count, all finite."""
    n = int(s.get("num_pts", -1))
    data, x = np.asarray(s.get("data", ())), np.asarray(s.get("x", ()))
    if data.shape != (n,) or x.shape != (n,):
        raise ConfigError(f"{path}: dataset {index} (58) {str(s.get('id1', '')).strip()!r}: header says {n} points, "
                          f"found {data.size} values and {x.size} abscissae")
    if not (np.all(np.isfinite(data)) and np.all(np.isfinite(x))):
        raise ConfigError(f"{path}: dataset {index} (58) {str(s.get('id1', '')).strip()!r}: values that are not "
                          "finite numbers")


def check_nodes(path: Path, index: int, s: dict) -> None:
    """A parsed node dataset (15/2411): every column as long as the node list, coordinates finite,
    node numbers unique."""
    nums = np.asarray(s.get("node_nums", ()))
    for column in ("def_cs", "disp_cs", "x", "y", "z"):
        if np.asarray(s.get(column, ())).shape != nums.shape:
            raise ConfigError(f"{path}: dataset {index} ({s.get('type')}): column {column} does not have one value "
                              f"per node ({nums.size})")
    if not np.all(np.isfinite(np.column_stack([s["x"], s["y"], s["z"]]))):
        raise ConfigError(f"{path}: dataset {index} ({s.get('type')}): node coordinates that are not finite numbers")
    if np.unique(nums).size != nums.size:
        raise ConfigError(f"{path}: dataset {index} ({s.get('type')}): a node number appears twice")


def check_trace(path: Path, index: int, s: dict) -> None:
    """A parsed trace line (82): as many nodes as its count (pyuff keeps the zeros that fill the last
    line of 8)."""
    n, nodes = int(s.get("n_nodes", -1)), np.asarray(s.get("nodes", ()))
    if not (n <= nodes.size < n + 8 and not np.any(nodes[n:])):
        raise ConfigError(f"{path}: dataset {index} (82) {str(s.get('id', '')).strip()!r}: says {n} nodes, "
                          f"lists {nodes.size}")


def check_references(path: Path, sets: list[dict]) -> None:
    """Trace lines and functions name only nodes the file defines (when it defines any)."""
    defined = {int(n) for s in sets if s.get("type") in (15, 2411) for n in np.asarray(s["node_nums"])}
    if not defined:
        return
    for index, s in enumerate(sets, start=1):
        if s.get("type") == 82:
            used = [int(n) for n in np.asarray(s["nodes"]) if int(n) != 0]  # 0 lifts the pen
        elif s.get("type") == 58:
            used = [int(s.get(k, 0)) for k in ("rsp_node", "ref_node") if int(s.get(k, 0)) > 0]
        else:
            continue
        missing = sorted(set(used) - defined)
        if missing:
            raise ConfigError(f"{path}: dataset {index} ({s.get('type')}) names node {missing[0]}, which the "
                              f"file's {len(defined)} nodes do not include")


def _show(line: bytes) -> str:
    return repr(line.decode("utf-8", "replace").strip()[:40])
