"""The vRTHS benchmark (``./pd rths_benchmark``).

The command is :mod:`.rths_benchmark`; the problem, the loops, the criteria J1-J9 and the
figures are in :mod:`.core`.
"""
