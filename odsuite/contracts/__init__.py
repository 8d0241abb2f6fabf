"""What a provider (a built-in or a lab's plugin) must be, and how providers are found: one contract
module per provider kind (DAQ backends, processing steps, coordinate solvers, effects, renderers,
importers, sensor types), the registries, the pluggy hook specifications and the plugin manager.
Imports only odsuite.domain.
"""
