"""Signals into coordinates: records streamed into a project, processing chains run chunk by chunk,
every body's generalized coordinates by its solver, the rig's sensor layout. Imports the store,
contracts and domain.
"""
