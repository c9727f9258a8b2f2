"""Actuator drivers: the interface, the registry and one module per controller family.

* :mod:`.base`: :class:`~.base.ActuatorDriver` (the interface), :class:`~.base.RemoteDriver`.
* :mod:`.registry`: name -> :class:`~.registry.DriverSpec` (factory, parameters).
* ``emulator``: :mod:`.emulator_driver` (:class:`~.emulator_driver.EmulatorDriver`) on
  :mod:`.emulator` (the servo-hydraulic actuator emulator; its parameters in
  :mod:`.emulator_parameters`) and :mod:`.ramp_hold` (its ramp-and-hold executor).
* ``generic_tcp``: :mod:`.generic_tcp` (OpenFresco GenericTCP client), wire format in
  :mod:`.generic_tcp_protocol`.
* ``opensees_adapter``: :mod:`.opensees_adapter` (client of OpenSees's adapter element).
* ``daqmx``: :mod:`.daqmx` (NI DAQ analog I/O), its configuration in :mod:`.daqmx_config`.
* ``transfer_system``: :mod:`.transfer_system` (a continuous actuator of real-time hybrid
  simulation, :mod:`pd_common.rths`, in simulated or wall-clock time); its plant may be the
  emulator (:mod:`.emulator_plant`, ``plant: {model: emulator}``).

Importing this package registers those five drivers; the node shell adds ``sim_servo``.
"""

from __future__ import annotations

# Importing the driver modules registers their drivers.
from . import (
    daqmx,
    emulator_driver,
    emulator_plant,
    generic_tcp,
    opensees_adapter,
    transfer_system,
)

__all__ = ['daqmx', 'emulator_driver', 'emulator_plant', 'generic_tcp', 'opensees_adapter',
           'transfer_system']
