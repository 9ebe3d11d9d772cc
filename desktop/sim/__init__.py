"""Simulators: RocketPy trajectories, sensor models, the seed paper's flight model, register-level fakes."""
