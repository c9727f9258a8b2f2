"""The vRTHS benchmark problem (Silva, Dyke et al. 2020) in the integrator's pure core.

:mod:`.problem` (the reference structure's cases, the partition, the ground motion, the
reference response), :mod:`.benchmark_loop` (the benchmark's own loop), :mod:`.criteria`
(J1–J9 and the noise floor). Pure: numpy/scipy and :mod:`pd_common.rths`, no ROS.
"""
