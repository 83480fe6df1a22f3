"""The search strategies, one module each; the shared protocol and candidate search in :mod:`.base`.

* :mod:`.dycors` — MSRS/DYCORS (Samuelsson 2023, Algorithm 4), the default:
  perturbation candidates scored by weighted surrogate value and distance;
* :mod:`.kriging_ei` — expected improvement on a Kriging surrogate
  (Samuelsson 2023, sec. 2.2.2.3);
* :mod:`.response_ei` — expected improvement of the objective computed from
  one model per response;
* :mod:`.rackl_hanley` — Rackl & Hanley's (2017) sampling, then
  Levenberg–Marquardt on the response models and on the simulations.

Each is registered by name in :data:`demcal.optimizer.registry.STRATEGIES`,
with what the optimizer must know of it (default surrogate, whether it
needs the targets, ...). Adding one: subclass :class:`.base.Strategy` (or
:class:`.base.CandidateSearch`) and register it.
"""
