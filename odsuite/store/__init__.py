"""The project file: HDF5 layout, codecs, checksums and damage reports, migrations, transactions by
temporary copy, the writer lock, disk-space checks. Imports odsuite.domain and odsuite.contracts.
"""
