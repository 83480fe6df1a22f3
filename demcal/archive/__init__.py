"""The archive: every simulation demcal runs, kept once with its provenance (issue 21).

- :mod:`demcal.archive.store`: ``Archive`` (open, add, records, compatible, stats);
- :mod:`demcal.archive.simulation`: ``ArchivedSimulation`` and ``from_results``, the record of a
  scene replicate from its results files;
- :mod:`demcal.archive.schema`: the tables; ``migrations/``: their Alembic migrations;
- :mod:`demcal.archive.importer`: ``demcal archive import``;
- :mod:`demcal.archive.export`: the archive as a table, CSV or Parquet;
- :mod:`demcal.results.archive_url`: where an archive lives (SQLite file or PostgreSQL URL).

This package imports nothing at its top: the study model reads :mod:`demcal.results.archive_url`,
and the record modules read the study model.
"""
