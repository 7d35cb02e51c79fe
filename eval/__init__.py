"""What measures and reports the package, kept out of the installed package: the speed and memory
benchmarks (``benchmarks/``), the studies behind paragraphs of the docs (``studies/``) and the
generators of the docs tables (``tables/``). Run from the repository root, e.g.
``python -m eval.benchmarks.bench_sfa``."""
