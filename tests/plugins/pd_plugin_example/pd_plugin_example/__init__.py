"""Example plug-ins for the pseudo-dynamic test system (see ``pyproject.toml``).

* :mod:`.spring`: the hysteresis model ``linear_spring`` (group ``pd.hysteresis``);
* :mod:`.rig`: the actuator driver ``spring_rig`` (group ``pd.drivers``);
* :mod:`.scheme`: the integration scheme ``central_difference`` (group ``pd.schemes``);
* :mod:`.rths`: the compensator ``scaled`` (group ``pd.compensators``) and the plant model
  ``scaled_ideal`` (group ``pd.plants``).

Nothing here registers itself on import: the entry points name the registry entries, and each
registry loads its group the first time it is asked for a name.
"""
