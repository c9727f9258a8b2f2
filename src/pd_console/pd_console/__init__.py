"""The live test console (a node and a web page): watch, steer and stop a test.

The node shell is :mod:`.console`; the pure parts (access control, the live model, run folders)
are in :mod:`.core`.
"""
