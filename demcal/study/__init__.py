"""The study: its model, the parameter catalogue, the config reader, the objective and a
material taken from a calibration (``material``)."""
