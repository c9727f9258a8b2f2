"""pd_integrator: the time-stepping side of the pseudo-dynamic test (core + ROS 2 node)."""
