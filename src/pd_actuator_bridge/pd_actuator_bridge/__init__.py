"""Actuator bridge: the safety boundary between the pseudo-dynamic integrator and the actuator.

The pure core (:mod:`pd_actuator_bridge.core`) enforces the bridge's own displacement, increment,
velocity and force limits whatever the integrator sends, and holds position on any fault. The
node shell wires it to the step command and feedback topics.
"""
