"""odsuite built-in plugin: importers of other tools' measurement files.

* ``legacy``: the thesis's .DAT/.VIZ records with their .CTR Systeminfo,
* ``lvm``: LabVIEW Measurement text files,
* ``uff``: universal file format time records (dataset 58) and FRFs,
* ``csv``, ``npy``, ``mat``, ``tdms``: records as arrays of numbers (with a sidecar for what they
  do not say),
* ``geometry``: a structure's nodes, lines, faces and sensors (TOML, CSV, UFF 15/82).
"""

from odsuite.api import hookimpl

#: the importers ``providers.builtin_importers`` makes, named here so that registering imports
#: neither them nor the importer contract
IMPORTERS = ("legacy", "lvm", "uff", "csv", "npy", "mat", "tdms", "geometry")


def _importer(name: str):
    from .providers import builtin_importers

    return next(i for i in builtin_importers() if i.name == name)


@hookimpl
def odsuite_register_importers(registry):
    for name in IMPORTERS:  # each made on first use: every command starts at once
        registry.add_deferred(name, lambda name=name: _importer(name))
