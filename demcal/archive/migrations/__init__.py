"""The archive's Alembic migrations (``env.py`` and ``versions/``), shipped in the package and
run by :func:`demcal.archive.store.upgrade` whenever an archive is opened."""
