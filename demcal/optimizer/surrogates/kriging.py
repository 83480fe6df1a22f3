"""Universal Kriging (Rackl & Hanley 2017): SMT's KRG, Matérn 5/2 kernel, linear drift, nugget.

Both an objective surrogate and a response model: it predicts a standard
deviation, and a refit can start from the previous fit's hyperparameters.
It gets the values uncapped: its nugget estimate would absorb a capped
plateau as noise.
"""

from __future__ import annotations

import warnings
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike

from .base import HyperparameterSearch, ResponseModel, TrainingData

#: A Kriging nugget (relative to the process variance) this large leaves only the trend.
DEGENERATE_NUGGET = 1e6
#: The nugget search starts at least here (a start at ~0 stays at an interpolating fit).
NUGGET_START_MIN = 1e-6


class KrigingSurrogate(ResponseModel):
    """Universal Kriging (Rackl & Hanley 2017): SMT KRG, Matérn 5/2, linear drift, nugget.

    The nugget (``eval_noise``) is estimated by maximum likelihood; the mean
    replicate variance, when given, is its starting value. A ``warm_start``
    (length scales, nugget) of a previous fit starts the search there instead.
    A fit whose noise (nugget times process variance) falls below the
    ``noise_floor`` is refitted with the nugget bounded there.
    """

    caps_large_values = False  # capping plus a nugget made the fit mostly trend and noise

    def __init__(
        self,
        duplicate_tolerance: float = 1e-7,
        restarts: int = 5,
        seed: int = 0,
        warm_start: tuple[np.ndarray, float] | None = None,
    ):
        super().__init__(duplicate_tolerance)
        self.restarts = restarts
        self.seed = seed
        #: start of the hyperparameter search, (length scales, nugget): a previous fit's optimum
        self.start = warm_start

    @classmethod
    def searching(cls, duplicate_tolerance: float, search: HyperparameterSearch) -> Self:
        """With a warm start, one start of the hyperparameter search, else ``restarts``."""
        warm = search.warm_start
        return cls(
            duplicate_tolerance,
            restarts=1 if warm is not None else search.restarts,
            seed=search.seed,
            warm_start=warm,
        )

    def _fit_standardised(self, data: TrainingData) -> None:
        self.model = self._train(data, self.start[1] if self.start is not None else None)
        floor = self.noise_floor / data.scale**2
        if self._noise_variance() < floor:  # refit with the nugget held above the measured scatter
            sigma2 = float(np.ravel(self.model.optimal_par["sigma2"])[0])
            self.model = self._train(data, floor / sigma2, lowest=floor / sigma2)

    def _noise_variance(self) -> float:
        """The fitted noise variance in standardised units: nugget times process variance."""
        nugget = float(np.ravel(self.model.optimal_noise)[0])
        return nugget * float(np.ravel(self.model.optimal_par["sigma2"])[0])

    def _train(self, data: TrainingData, nugget: float | None, lowest: float | None = None) -> Any:
        """SMT's KRG trained on ``data``, its nugget search starting at ``nugget`` (default: the
        mean replicate variance) and bounded below by ``lowest``."""
        from smt.surrogate_models import KRG

        n, d = data.x.shape
        trend = "linear" if n > 2 * (d + 1) else "constant"
        model = KRG(
            corr="matern52",
            poly=trend,
            eval_noise=True,
            noise0=[
                max(float(np.mean(data.noise)) if nugget is None else nugget, NUGGET_START_MIN)
            ],
            hyper_opt="Cobyla",
            n_start=self.restarts,
            seed=self.seed,
            print_global=False,
            **(
                {}
                if self.start is None or len(self.start[0]) != d
                else {"theta0": list(self.start[0])}
            ),
            **({} if lowest is None else {"noise_bounds": [lowest, 1e10]}),
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model.set_training_values(data.x, data.z)
            model.train()
        return model

    @property
    def noise_sd(self) -> float:
        """The fitted noise, and never less than the ``noise_floor``: the refit bounds the nugget
        relative to the process variance, which a fit that is all trend can still shrink."""
        if self.constant:
            return 0.0
        assert self.data is not None, "a surrogate has a noise once fitted"
        fitted = self.data.scale * float(np.sqrt(max(self._noise_variance(), 0.0)))
        return max(fitted, float(np.sqrt(self.noise_floor)))

    def _predict_standardised(self, x: np.ndarray) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            values: np.ndarray = self.model.predict_values(x).ravel()
        return values

    @property
    def warm_start(self) -> tuple[np.ndarray, float] | None:
        """(length scales, nugget) of this fit, to start the next fit from; None when there is
        nothing to start from or the fit is degenerate (a nugget so large that only the trend
        is left: a start there stays there)."""
        if self.constant:
            return None
        nugget = float(np.ravel(self.model.optimal_noise)[0])
        if nugget >= DEGENERATE_NUGGET:
            return None
        return np.asarray(self.model.optimal_theta, float), nugget

    def predict_std(self, x: ArrayLike) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, float))
        if self.constant:
            return np.zeros(len(x))
        assert self.data is not None, "a surrogate predicts once fitted"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            variance = self.model.predict_variances(x).ravel()
        std: np.ndarray = self.data.scale * np.sqrt(np.maximum(variance, 0.0))
        return std
