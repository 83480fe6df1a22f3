"""One module per schema version of the archive, oldest first (Alembic revisions)."""
