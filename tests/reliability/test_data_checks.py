"""Data checks: a byte flipped anywhere inside stored raw or derived data is caught by its checksum
and named by `odsuite verify` and `odsuite info`; the intact experiments stay readable."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from odsuite.cli import main
from odsuite.domain.errors import ProjectFileError
from odsuite.store.project import DerivedArray, create_project, open_project
from odsuite.domain.systeminfo import ChannelInfo, Systeminfo

CHANNELS = 3


@pytest.fixture
def project(tmp_path):
    path = tmp_path / "p.h5"
    rng = np.random.default_rng(5)
    with create_project(path, rig=None) as p:
        for name in ("a", "b"):
            # 2 raw chunks of 1 MiB each plus a part: several chunks to damage
            p.add_experiment(name, rng.normal(size=(100_000, CHANNELS)), sampling_rate=1000.0,
                             systeminfo=Systeminfo([ChannelInfo() for _ in range(CHANNELS)]), excitation=None)
        p.write_derived("a", "velocity", {"v": DerivedArray(rng.normal(size=(5000, CHANNELS)), "m/s",
                                                             ("sample", "channel"))},
                        provenance={"plugin": "test"})
    return path


def _chunks(path, dataset):
    with h5py.File(path, "r") as f:
        ds = f[dataset]
        return [(ds.id.get_chunk_info(i).byte_offset, ds.id.get_chunk_info(i).size)
                for i in range(ds.id.get_num_chunks())]


def _flip(path, offset):
    with open(path, "r+b") as fh:
        fh.seek(offset)
        byte = fh.read(1)[0]
        fh.seek(offset)
        fh.write(bytes([byte ^ 0xFF]))


def test_intact_project_verifies(project, capsys):
    assert main(["verify", str(project)]) == 0
    assert capsys.readouterr().out.strip() == f"{project}: 3 checksummed datasets in 2 experiments read back intact"


@pytest.mark.parametrize("dataset, experiment", [
    ("/experiments/b/raw", "b"),
    ("/experiments/a/derived/velocity/v", "a"),
])
def test_flipped_byte_is_found_and_named(project, capsys, dataset, experiment):
    rng = np.random.default_rng(11)
    chunks = _chunks(project, dataset)
    clean = project.read_bytes()
    # first byte, last byte (the stored checksum) and seeded bytes in between, each on its own
    for k, (offset, size) in enumerate(chunks):
        for at in sorted({0, size - 1, *rng.integers(0, size, 3).tolist()}):
            project.write_bytes(clean)
            _flip(project, offset + at)
            assert main(["verify", str(project)]) == 1, (k, at)
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and "Traceback" not in err
            assert err.startswith(f"error: {project}: experiment {experiment!r}: dataset {dataset} is corrupted "
                                  "(checksum failed:"), err
    if dataset.endswith("raw"):
        assert main(["info", str(project)]) == 1  # info reads the raw data too, and says which
        err = capsys.readouterr().err
        assert err.count("\n") == 1
        assert f"experiment {experiment!r}: raw data cannot be read (corrupted?)" in err
    with open_project(project) as p:  # the intact experiment stays readable
        intact = "a" if experiment == "b" else "b"
        assert p.experiment(intact).raw().shape == (100_000, CHANNELS)
        with pytest.raises(ProjectFileError):
            p.verify()


HEAP_LOOP = Path(__file__).resolve().parents[1] / "data" / "damaged" / "heap-loop-1.0.0.h5"


@pytest.mark.parametrize("mode", ["r", "a"])
def test_a_1_0_0_file_whose_damaged_heap_hangs_hdf5_is_an_error(tmp_path, monkeypatch, mode):
    """A fuzzing find: reading the root text of this damaged format-1.0.0 file sends HDF5's
    global-heap reader into an endless loop. Format-1.0.0 files are migrated in a child process,
    which is stopped."""
    from odsuite.store import project_migration

    monkeypatch.setattr(project_migration, "HEAP_TEXT_TIMEOUT", 2.0)
    path = tmp_path / "x.h5"
    shutil.copyfile(HEAP_LOOP, path)
    before = path.read_bytes()
    with pytest.raises(ProjectFileError) as info:
        open_project(path, mode)
    assert str(info.value) == (f"{path}: project file is damaged (reading its format-1.0.0 text did not finish "
                               "within 2 s)")
    assert path.read_bytes() == before
