"""odsuite built-in plugin: importers of other tools' measurement files.

* ``legacy``: the thesis's .DAT/.VIZ records with their .CTR Systeminfo,
* ``lvm``: LabVIEW Measurement text files,
* ``uff``: universal file format time records (dataset 58) and FRFs,
* ``csv``, ``npy``, ``mat``, ``tdms``: records as arrays of numbers (with a sidecar for what they
  do not say),
* ``geometry``: a structure's nodes, lines, faces and sensors (TOML, CSV, UFF 15/82).
"""

from odsuite.api import hookimpl


@hookimpl
def odsuite_register_importers(registry):
    from .providers import (
        builtin_importers,  # on first use: `odsuite --help` starts fast
    )

    for importer in builtin_importers():
        registry.add(importer.name, importer)
