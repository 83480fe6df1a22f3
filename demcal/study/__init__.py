"""The study: its model (``model``), the study file read and checked (``study_file``,
``schema``, ``config``, ``targets``, ``units``) and a material taken from a calibration
(``material``). The parameter catalogue is in ``demcal.physics.catalogue``, the objective in
``demcal.optimizer.objective``."""
