"""Published figures: the tables of README.md and docs/ generated from the committed result
files under ``published/`` (:mod:`eval.tables.tables`)."""
