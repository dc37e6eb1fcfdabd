"""Robot model files the tests generate (no shipped binaries): :mod:`.urdf_humanoid`."""
