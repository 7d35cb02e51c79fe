"""Speed and memory benchmarks: each times what it measures against a reference run in the same
process and prints the ratios. Run from the repository root as ``python -m eval.benchmarks.<name>``;
the result files they write live in ``published/benchmarks/``."""
