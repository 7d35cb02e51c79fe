"""Recording runs: drivers, orderings, the run file format and the recorder/replay loop."""
