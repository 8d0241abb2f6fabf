"""Corrupted UFF files (cut off, a line lost or doubled, a byte changed, a count changed): each is refused in one line
or read back identical to the original. UFF has no checksum, so a byte changed inside a number or a
label can be read as another number or label: that case alone may read other text or values, never
another structure (dataset and function types, counts, lengths, nodes, directions, node links).
A file cut exactly at the end of a dataset is a valid shorter file: counted apart.
Seeded: the same files on every run; ``UFF_FUZZ_FILES`` sets how many per base file."""

from __future__ import annotations

import os
import random
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from odsuite.domain.errors import OdsuiteError
from odsuite_plugins.importers.uff import UffGeometry, read_uff, time_function, write_uff

FILES = int(os.environ.get("UFF_FUZZ_FILES", "150"))  # per base file: 2 x 150 = 300 in the fast suite
KINDS = ("cut", "line-lost", "line-doubled", "byte-changed", "count-changed")


def _base(folder: Path, binary: bool) -> Path:
    path = folder / f"base{int(binary)}.uff"
    geometry = UffGeometry(np.array([1, 2, 3]), np.eye(3), np.zeros(3, int), trace_lines=[("t", [1, 2, 3])])
    functions = [time_function(f"acc{k}", np.sin(np.arange(32) / 3 + k), 1e-3, "m/s^2", node=1 + k % 3, direction=3)
                 for k in range(5)]
    write_uff(path, functions=functions, geometry=geometry, binary=binary)
    return path


def _content(path: Path):
    """(structure, labels, values) of what odsuite reads: structure is the dataset types, function
    types, lengths, nodes, directions and node links; labels the free text (names, units, notes);
    values the numbers measured."""
    c = read_uff(path)
    g = c.geometry
    structure = (c.dataset_types,
                 [(f.func_type, f.x.shape, f.data.shape, f.data.dtype.str, f.rsp_node, f.rsp_dir, f.ref_node,
                   f.ref_dir) for f in c.functions],
                 None if g is None else (g.node_nums.tolist(), g.disp_cs.tolist(), [t[1] for t in g.trace_lines]))
    labels = ([(f.name, f.unit, f.x_unit, f.description) for f in c.functions],
              None if g is None else [t[0] for t in g.trace_lines])
    values = ([(f.x.tobytes(), f.data.tobytes()) for f in c.functions], None if g is None else g.xyz.tobytes())
    return structure, labels, values


def _corrupt(good: bytes, kind: str, rng: random.Random) -> bytes:
    lines = good.split(b"\n")
    if kind == "cut":
        return good[:rng.randrange(1, len(good) - 1)]
    if kind == "line-lost":
        del lines[rng.randrange(len(lines) - 1)]
        return b"\n".join(lines)
    if kind == "count-changed":  # the point count of a function (record 7) or a trace line's node count
        counts = [j for j, line in enumerate(lines) if len(line.split()) in (3, 6) and line.split()[1] in (b"32", b"3")
                  and all(t.isdigit() for t in line.split()[:3])]
        j = rng.choice(counts)
        cells = lines[j].split()
        old = cells[1]
        new = str(rng.choice([n for n in range(0, 100) if str(n).encode() != old])).encode()
        at = lines[j].index(b" " + old + b" ") + 1
        lines[j] = lines[j][:at] + new.rjust(len(old)) + lines[j][at + len(old):] if len(new) <= len(old) else \
            lines[j][:at - len(new) + len(old)] + new + lines[j][at + len(old):]
        return b"\n".join(lines)
    if kind == "line-doubled":
        j = rng.randrange(len(lines) - 1)
        lines.insert(j, lines[j])
        return b"\n".join(lines)
    data = bytearray(good)
    j = rng.randrange(len(data))
    data[j] = (data[j] + rng.randrange(1, 256)) % 256  # a different byte
    return bytes(data)


def fuzz(folder: Path, binary: bool, files: int, seed: int) -> Counter:
    base = _base(folder, binary)
    good, reference = base.read_bytes(), _content(base)
    rng = random.Random(seed)
    out: Counter = Counter()
    for k in range(files):
        kind = KINDS[k % len(KINDS)]
        bad = folder / f"bad{k}.uff"
        data = _corrupt(good, kind, rng)
        bad.write_bytes(data)
        try:
            content = _content(bad)
            result = "identical" if content == reference else \
                "text or values changed" if content[0] == reference[0] else "structure changed"
            if result == "structure changed" and kind == "cut" and data.rstrip().endswith(b"-1"):
                result = "cut at a dataset's end"  # a file of fewer datasets: no count to tell
        except OdsuiteError as exc:
            result = "refused" if "\n" not in str(exc) and str(bad) in str(exc) else f"bad message: {exc!r}"
        except Exception as exc:  # noqa: BLE001 - what the fuzzer looks for
            result = f"other {type(exc).__name__}: {exc}"
        assert bad.read_bytes() == data  # reading never changes the file
        bad.unlink()
        out[kind, result] += 1
    return out


@pytest.mark.parametrize("binary", [False, True], ids=["ascii-58", "binary-58b"])
def test_corrupted_uff_is_refused_or_read_identically(tmp_path, binary):
    counts = fuzz(tmp_path, binary, FILES, seed=17)
    print(f"binary={binary}: {sorted(counts.items())}")
    assert sum(counts.values()) == FILES
    allowed = ("refused", "identical", "text or values changed", "cut at a dataset's end")
    odd = {key: n for key, n in counts.items() if key[1] not in allowed}
    assert not odd, odd  # no other exception, no message but one line naming the file, no other structure
    # a cut, a lost or a doubled line, a changed count never passes as a file with other text or values
    assert not any(counts[kind, "text or values changed"] for kind in KINDS if kind != "byte-changed"), counts
    # a changed byte inside a number or a label is a number or a label (UFF has no checksum): that case
    # alone reads other values; a cut exactly at a dataset's end leaves a shorter valid file
    assert counts["cut", "cut at a dataset's end"] <= 2, counts
