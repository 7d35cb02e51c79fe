"""The scripts behind paragraphs of the docs: each names its docs page in its docstring and takes
its settings as a tyro ``Args`` dataclass. Run from the repository root as
``python -m eval.studies.<name>``; the result files they write live in ``published/studies/``."""
