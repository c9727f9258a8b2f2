"""Bring-up of a pseudo-dynamic test: ``run_test`` starts every node as its own process."""
