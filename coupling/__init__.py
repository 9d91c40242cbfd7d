"""Coupling between the SPH side (sensor particles) and substrate backends (FEM, TL-SPH)."""
