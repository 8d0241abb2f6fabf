"""The things vibration engineers talk about, with no storage or providers: errors, rigs (bodies,
sensors, springs, acquisition), rigid-body kinematics, the Systeminfo channel table, where a hammer
hit, the linear multibody model and its exact simulation. Imports nothing of odsuite outside this
package.
"""
