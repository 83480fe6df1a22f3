"""A response of this material taught by its neighbours: fixed parameters as model inputs.

The archive holds runs of other materials on the same simulator: another particle density,
another wall friction. Their responses are not this material's, but near it they vary
smoothly with those parameters. So the model of a response takes, beyond the free
parameters, each fixed parameter in which a neighbour differs from the study, as its offset
from the study's value (this study's own runs at offset 0), and predicts at offset 0: the
transfer of Hadi et al. (2024) from neighbouring materials, done by a Gaussian process over
the joint space. It is :class:`~.kriging.KrigingSurrogate` (Matérn 5/2, linear drift once the
data allow it, nugget, the noise floor of this study's replicates) on the joint inputs, so the
drift learns a response's trend with the material (a bulk density in proportion to the
particle density) and the length scales how far a neighbour's runs carry.

Each offset is divided by its largest size among the data, so that the material inputs span
about a unit as the free ones do (SMT standardises its inputs as well, so this changes no
fit; it keeps the inputs readable and the duplicate check in unit-box terms). An offset
that is the same for every run carries nothing and is left out: before this study's first
run, the neighbours stand for it as they are.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Self

import numpy as np
from numpy.typing import ArrayLike

from .kriging import KrigingSurrogate


def material_inputs(offsets: np.ndarray) -> np.ndarray:
    """Scale of each material column that varies among the rows of ``offsets`` (its largest
    size), 0 for a column that does not (left out of the model)."""
    varies = np.ptp(offsets, axis=0) > 0 if len(offsets) else np.zeros(offsets.shape[1], bool)
    largest = np.max(np.abs(offsets), axis=0) if len(offsets) else np.zeros(offsets.shape[1])
    return np.where(varies, largest, 0.0)


class MaterialKriging:
    """This material's response from its own runs and its neighbours' (the module's model).

    ``predict``, ``predict_std`` and ``noise_sd`` are at the study's own material, over the
    free parameters (unit box), as a single-material response model's are, so every user of
    the response models takes it unchanged.
    """

    def __init__(self, duplicate_tolerance: float = 1e-7, restarts: int = 5, seed: int = 0):
        self.model = KrigingSurrogate(duplicate_tolerance, restarts, seed)
        self.scale = np.zeros(0)

    def fit(
        self,
        x: np.ndarray,
        y: np.ndarray,
        variance: np.ndarray,
        offsets: np.ndarray,
        noise_floor: float = 0.0,
    ) -> Self:
        """Fit on points ``x`` (unit box), values ``y`` and their ``variance``; ``offsets``:
        per point, each material parameter's offset from the study's value (0 on its own
        runs); ``noise_floor``: the variance of single simulations of this material."""
        self.scale = material_inputs(offsets)
        self.model.fit(self._joint(x, offsets), y, variance, noise_floor=noise_floor)
        return self

    def _joint(self, x: ArrayLike, offsets: np.ndarray | None = None) -> np.ndarray:
        """Points of the free parameters joined with their scaled material inputs (the study's
        own material, 0, without ``offsets``)."""
        x = np.atleast_2d(np.asarray(x, float))
        kept = self.scale > 0
        inputs = np.zeros((len(x), int(kept.sum())))
        if offsets is not None:
            inputs = offsets[:, kept] / self.scale[kept]
        return np.hstack([x, inputs])

    def predict(self, x: ArrayLike) -> np.ndarray:
        return self.model.predict(self._joint(x))

    def predict_std(self, x: ArrayLike) -> np.ndarray:
        return self.model.predict_std(self._joint(x))

    @property
    def noise_sd(self) -> float:
        return self.model.noise_sd


def offsets_matrix(materials: Sequence[dict[str, float]], names: Sequence[str]) -> np.ndarray:
    """Per point, its offset in each of ``names`` (0 where a point does not differ)."""
    return np.array([[m.get(n, 0.0) for n in names] for m in materials], float).reshape(
        len(materials), len(names)
    )
