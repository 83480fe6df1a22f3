"""Multi-fidelity Kriging of one response: cheap levels teach the fine one (SMT's MFK).

The recursive co-Kriging of Le Gratiet & Garnier (2014), after Kennedy & O'Hagan (2000):
each level is the level below it, scaled, plus a discrepancy,

    y_fine(x) = rho * y_coarse(x) + delta(x),

with a Gaussian process for the cheapest level and one for each discrepancy, fitted by
maximum likelihood level by level. So a coarse level's bias is learnt (rho and delta), not
assumed away: where coarse runs are many and fine ones few, the fine prediction follows the
coarse shape and its own data fix the offset and scale. The levels' designs need not be
nested (SMT predicts the level below at the points of the level above).

Like :class:`~.kriging.KrigingSurrogate` (Matérn 5/2, a nugget estimated per level), it
predicts the fine level's mean and standard deviation, and its noise never below the scatter
of fine simulations measured from replicates (the ``noise_floor``).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike

from demcal.optimizer.levels import LevelOutlook

from .kriging import NUGGET_START_MIN


@dataclass(frozen=True)
class LevelData:
    """One level's training data: points (unit box), values and each value's variance."""

    x: np.ndarray
    y: np.ndarray
    variance: np.ndarray


class MultiFidelityKriging:
    """The fine level's response from every level's data (the module's model).

    ``fit`` takes the levels cheapest first and the fine level last; ``predict``,
    ``predict_std`` and ``noise_sd`` are the fine level's, as a single-level response model's
    are, so the response strategies use it unchanged.
    """

    def __init__(self, restarts: int = 5, seed: int = 0):
        self.restarts, self.seed = restarts, seed
        self.offset, self.scale = 0.0, 1.0
        self.noise_floor = 0.0
        self.model: Any = None

    def fit(self, levels: Sequence[LevelData], noise_floor: float = 0.0) -> Self:
        """Fit on ``levels`` (cheapest first, fine last; each needs a point); ``noise_floor``:
        the variance of single fine simulations, below which ``noise_sd`` does not fall."""
        from smt.applications.mfk import MFK

        if len(levels) < 2 or any(len(level.y) == 0 for level in levels):
            raise ValueError("a multi-fidelity model needs two levels or more, each with data")
        values = np.concatenate([level.y for level in levels])
        self.offset = float(np.mean(values))
        spread = float(np.std(values))
        self.scale = spread if spread > 1e-12 * max(1.0, abs(self.offset)) else 1.0
        self.noise_floor = noise_floor
        dimension = levels[-1].x.shape[1]
        self.model = MFK(
            corr="matern52",
            poly="constant",
            rho_regr="constant",
            eval_noise=True,
            noise0=[
                [max(float(np.mean(level.variance)) / self.scale**2, NUGGET_START_MIN)]
                for level in levels
            ],
            theta0=[0.5] * dimension,
            hyper_opt="Cobyla",
            n_start=self.restarts,
            seed=self.seed,
            print_global=False,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for index, level in enumerate(levels[:-1]):
                self.model.set_training_values(level.x, self._standard(level.y), name=index)
            self.model.set_training_values(levels[-1].x, self._standard(levels[-1].y))
            self.model.train()
        return self

    def _standard(self, y: np.ndarray) -> np.ndarray:
        return (np.asarray(y, float) - self.offset) / self.scale

    @property
    def rho(self) -> float:
        """The fitted scale of the level below in the fine level (``rho`` above)."""
        return float(np.ravel(self.model.optimal_par[-1]["beta"])[0])

    def predict(self, x: ArrayLike) -> np.ndarray:
        """The fine level's predicted mean at the rows of ``x`` (unit box)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            values = self.model.predict_values(np.atleast_2d(np.asarray(x, float))).ravel()
        mean: np.ndarray = self.offset + self.scale * values
        return mean

    def predict_std(self, x: ArrayLike) -> np.ndarray:
        """The fine level's predicted standard deviation at the rows of ``x``."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            variance = self.model.predict_variances(np.atleast_2d(np.asarray(x, float))).ravel()
        std: np.ndarray = self.scale * np.sqrt(np.maximum(variance, 0.0))
        return std

    def level_noise_sd(self, level: int) -> float:
        """The fitted noise of level ``level`` (0 the cheapest; -1 fine): its nugget times its
        process variance, in response units."""
        nugget = float(np.ravel(self.model.optimal_noise_all[level])[0])
        sigma2 = float(np.ravel(self.model.optimal_par[level]["sigma2"])[0])
        return self.scale * float(np.sqrt(max(nugget * sigma2, 0.0)))

    @property
    def noise_sd(self) -> float:
        """The fine level's fitted noise, never below the ``noise_floor``."""
        return max(self.level_noise_sd(-1), float(np.sqrt(self.noise_floor)))

    def outlooks(self, x: ArrayLike) -> tuple[LevelOutlook, LevelOutlook]:
        """What a run at the point ``x`` would tell about the fine response, at the fine level
        and at the level below it: the posterior correlation with the fine value (rho s_c / s_f
        in the recursive model), the level's predictive sd and its noise."""
        point = np.atleast_2d(np.asarray(x, float))[:1]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            variances = np.maximum(self.model.predict_variances_all_levels(point)[0][0], 0.0)
        fine_sd = float(self.predict_std(point)[0])
        below, top = float(variances[-2]), float(variances[-1])
        below_sd = fine_sd * float(np.sqrt(below / top)) if top > 0.0 else 0.0
        correlation = self.rho * below_sd / fine_sd if fine_sd > 0.0 else 0.0
        return (
            LevelOutlook(1.0, fine_sd, self.noise_sd),
            LevelOutlook(float(np.clip(correlation, -1.0, 1.0)), below_sd, self.level_noise_sd(-2)),
        )
