"""The simulated robot: the thesis robot with a virtual patient on its handle, the
patients themselves, the simulated sensors, and fault injection for any backend.

May import core, device.backend and device.errors. Never device.hardware: a simulation
never touches a vendor API.
"""
