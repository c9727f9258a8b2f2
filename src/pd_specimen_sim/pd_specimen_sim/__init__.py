"""Simulated specimen of the pseudo-dynamic test (hysteresis models behind a ROS 2 node)."""
