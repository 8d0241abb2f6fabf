"""Work over many projects: batch runs (a local or a lab's dask cluster) and the project catalogue.
Imports every engine layer below; nothing imports it but the command line.
"""
