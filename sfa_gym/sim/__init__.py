"""The simulation: the env, the rover, headless GL, worlds and the omnidirectional camera."""
