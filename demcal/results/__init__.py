"""The results of a study on disk: where files live, the records they hold, the tables."""
