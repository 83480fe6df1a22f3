"""SMT's radial basis function model: a Gaussian kernel plus a linear tail."""

from __future__ import annotations

import numpy as np

from .base import Surrogate, TrainingData


class SMTRadialBasis(Surrogate):
    """SMT's RBF: Gaussian kernel of width ``d0`` (unit box) plus a linear tail."""

    def __init__(self, duplicate_tolerance: float = 1e-7, width: float = 0.5):
        super().__init__(duplicate_tolerance)
        self.width = width

    def _fit_standardised(self, data: TrainingData) -> None:
        from smt.surrogate_models.rbf import RBF

        self.model = RBF(d0=self.width, poly_degree=1, reg=1e-10, print_global=False)
        self.model.set_training_values(data.x, data.z)
        self.model.train()

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        return self.model.predict_values(x).ravel()
