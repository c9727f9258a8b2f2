"""Pre-test planning: the test's model under many records, scales and parameters at once.

The command is :mod:`.pretest`; the pure parts (plan, models, limits, spectra, report) are in
:mod:`.core`.
"""
