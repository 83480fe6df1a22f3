"""Surrogate models behind one fit/predict interface (:mod:`.base`), one module per model.

* :mod:`.cubic_rbf` — the thesis' cubic RBF with a linear tail and
  leave-one-out smoothing (Samuelsson 2023, eq. 2.10–2.11), and
  :class:`~.cubic_rbf.ResponseRBF`, its variant for one response;
* :mod:`.kriging` — universal Kriging with a Matérn 5/2 kernel, linear
  drift and nugget (Rackl & Hanley 2017), for the objective or a response;
* :mod:`.smt_rbf` — SMT's Gaussian RBF with a linear tail.

They are registered by name in :data:`demcal.optimizer.registry.SURROGATES`
(models of the objective) and :data:`~demcal.optimizer.registry.RESPONSE_MODELS`
(models of one response each, :class:`~.base.ResponseModel`).
"""
