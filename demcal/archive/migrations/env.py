"""Alembic's environment: migrate the connection that demcal.archive.store.upgrade hands over
(in its transaction, under its lock); there is no alembic.ini and no offline mode."""

from alembic import context

from demcal.archive.schema import Base

context.configure(
    connection=context.config.attributes["connection"],
    target_metadata=Base.metadata,
    version_table=context.config.attributes["version_table"],
    render_as_batch=True,  # SQLite alters a table by copying it
)
with context.begin_transaction():
    context.run_migrations()
