"""Shared pure library of the pseudo-dynamic test (numpy/scipy/PyYAML; no rclpy).

Subpackages, one concern each:

* :mod:`pd_common.protocol`: the step protocol's data types (command, feedback, status, key);
* :mod:`pd_common.specimen`: backbones, hysteresis models, specimens, the step server;
* :mod:`pd_common.experimental`: experimental-error models and tracking monitors;
* :mod:`pd_common.config`: the YAML loader;
* :mod:`pd_common.durable`: when a file written step by step is ``fsync``-ed (the run's
  journal, a simulator's state file), in the step or in a thread of its own;
* :mod:`pd_common.ros`: the only part that imports rclpy: QoS profiles, message conversion
  and stamps, used by every node.

The node and tool packages (``pd_integrator``, ``pd_actuator_bridge``, ``pd_specimen_sim``,
``pd_bringup``, ``pd_console``, ``pd_pretest``, ``pd_scheme_analysis``, ``pd_studies``,
``pd_rths_benchmark``) import this package, the integrator's pure core ``pd_core`` and
``pd_msgs``, never each other.
"""
