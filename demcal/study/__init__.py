"""The study: its model, the parameter catalogue, the config reader and the objective."""
