"""Initial experimental designs in the unit box [0, 1]^d.

Samuelsson (2023), section 2.2.2.1: a Latin hypercube design (LHD) puts one
point in each of n equal-probability slices of every axis; the symmetric
variant of Ye et al. (SLHD) pairs every row with its mirror image
n+1-x; among several random designs the maximin criterion keeps the one
whose closest pair of points is farthest apart. Rackl & Hanley (2017) start
from a plain LHS. Sobol and Halton sequences come from scipy.stats.qmc.
Richter & Will (2021, sec. 2.3) sample their material domain with FSSF-f
(Shang & Apley 2020) and judge a design by its minimum inter-site distance
and cover measure (their eqs. 7-8).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
from scipy.spatial.distance import cdist, pdist
from scipy.stats import qmc

from .registry import DESIGNS

#: An initial design: ``(size, dimension, rng) -> points`` in the unit box.
Design = Callable[[int, int, np.random.Generator], np.ndarray]


def default_initial_size(dimension: int, workers: int = 1) -> int:
    """Initial design size q + P with q = 2d + 1 (Samuelsson 2023, sec. 3.7, Table 4.2).

    The extra point per worker lets the adaptive phase start as soon as all
    design points are finished or running, so no worker idles.
    """
    return 2 * dimension + 1 + max(workers - 1, 0)


def latin_hypercube(size: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """One random LHD: each column a permutation of the slice centres (eq. 2.6)."""
    levels = np.column_stack([rng.permutation(size) for _ in range(dimension)])
    return (levels + 0.5) / size


def symmetric_latin_hypercube(size: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """One random SLHD (Ye et al., as described in Samuelsson 2023, sec. 2.2.2.1).

    For every row with levels x there is a row with levels n+1-x, so the
    design is symmetric about the centre of the box; with an odd size the
    middle row sits at the centre.
    """
    half = size // 2
    levels = np.empty((size, dimension))
    for column in range(dimension):
        first_half = rng.permutation(half) + 1.0
        flip = rng.random(half) < 0.5
        first_half[flip] = size + 1 - first_half[flip]
        levels[:half, column] = first_half
        levels[size - half :, column] = (size + 1 - first_half)[::-1]
        if size % 2:
            levels[half, column] = (size + 1) / 2
    return (levels - 0.5) / size


def sobol_sequence(size: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """The first ``size`` points of a scrambled Sobol sequence."""
    sampler = qmc.Sobol(dimension, scramble=True, seed=rng)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # balance warning for sizes not 2**m
        points: np.ndarray = sampler.random(size)
    return points


def halton_sequence(size: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """The first ``size`` points of a scrambled Halton sequence."""
    points: np.ndarray = qmc.Halton(dimension, scramble=True, seed=rng).random(size)
    return points


def forward_maximin(candidates: np.ndarray, taken: np.ndarray, size: int) -> np.ndarray:
    """``size`` of the ``candidates``, each the one farthest from the points ``taken`` and
    those chosen before it; with nothing taken the first is the candidate nearest the
    centre of the box (Kennard & Stone's greedy maximin, the forward step of FSSF-f)."""
    taken = np.asarray(taken, float).reshape(-1, candidates.shape[1])
    chosen = []
    if not len(taken) and size > 0:
        chosen.append(candidates[int(np.argmin(np.linalg.norm(candidates - 0.5, axis=1)))])
        taken = np.array(chosen)
    nearest = (
        cdist(candidates, taken).min(axis=1) if len(taken) else np.full(len(candidates), np.inf)
    )
    while len(chosen) < size:
        pick = candidates[int(np.argmax(nearest))]
        chosen.append(pick)
        nearest = np.minimum(nearest, np.linalg.norm(candidates - pick, axis=1))
    return np.array(chosen).reshape(size, candidates.shape[1])


def fssf_candidates(size: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """The candidate set of FSSF-f for a design of ``size``: 1000 d + 2 n scrambled Sobol
    points (the size Shang & Apley 2020 recommend)."""
    return sobol_sequence(1000 * dimension + 2 * size, dimension, rng)


def fssf_f(size: int, dimension: int, rng: np.random.Generator) -> np.ndarray:
    """FSSF-f after Shang & Apley (2020), Richter & Will's (2021) design: greedy maximin over
    a large candidate set, started at the centre (the refinements of their implementation are
    not reproduced). Every prefix of it is space-filling, so a campaign can stop and be
    extended (:func:`extend_design`)."""
    return forward_maximin(fssf_candidates(size, dimension, rng), np.empty((0, dimension)), size)


def minimum_pairwise_distance(points: np.ndarray) -> float:
    """The maximin criterion: the smallest distance between two design points."""
    if len(points) < 2:
        return np.inf
    return float(pdist(points).min())


def maximin_design(
    generate: Design, size: int, dimension: int, rng: np.random.Generator, tries: int
) -> np.ndarray:
    """Best of ``tries`` random designs by the maximin criterion."""
    best: np.ndarray | None = None
    best_distance = -np.inf
    for _ in range(tries):
        design = generate(size, dimension, rng)
        distance = minimum_pairwise_distance(design)
        if distance > best_distance:
            best, best_distance = design, distance
    assert best is not None, "tries >= 1 (the settings check design_tries), and any distance > -inf"
    return best


def fill_gaps(
    covered: np.ndarray, size: int, dimension: int, rng: np.random.Generator
) -> np.ndarray:
    """``size`` points that fill the unit box around the ``covered`` ones (at least one),
    greedy maximin.

    The candidates are a scrambled Sobol set of 1024 points; each step takes the candidate
    farthest from the covered points and from those taken before it. Simple and cheap, and
    it puts the first new points where the covered ones left the largest holes.
    """
    return forward_maximin(sobol_sequence(1024, dimension, rng), np.asarray(covered, float), size)


#: Designs whose every prefix is the design of its size: a campaign on them can be extended.
EXTENSIBLE = ("fssf_f", "sobol", "halton")


def extend_design(
    kind: str, taken: np.ndarray, size: int, dimension: int, rng: np.random.Generator
) -> np.ndarray:
    """The points that take a design of ``kind`` from the points ``taken`` (drawn from the same
    ``rng`` stream) to ``size``: a sequence's next points, or FSSF-f's next forward steps."""
    if kind not in EXTENSIBLE:
        raise ValueError(f"a {kind} design cannot be extended; use {', '.join(EXTENSIBLE)}")
    missing = max(size - len(taken), 0)
    if kind == "fssf_f":
        return forward_maximin(fssf_candidates(size, dimension, rng), taken, missing)
    generate: Design = DESIGNS[kind].load()
    return generate(size, dimension, rng)[len(taken) :]


def cover_measure(points: np.ndarray) -> float:
    """Cover measure (Richter & Will 2021, eq. 8, after Gunzburger & Burkardt): the
    coefficient of variation of each point's distance to its nearest neighbour; 0 for a
    regular grid, larger the more unevenly the points fill the box."""
    if len(points) < 2:
        return np.nan
    distances = cdist(points, points)
    np.fill_diagonal(distances, np.inf)
    nearest = distances.min(axis=1)
    return float(nearest.std() / nearest.mean())


def initial_design(
    kind: str,
    size: int,
    dimension: int,
    rng: np.random.Generator,
    tries: int = 50,
    include: np.ndarray | None = None,
    covered: np.ndarray | None = None,
) -> np.ndarray:
    """The initial design in the unit box, with user points first.

    Each point of ``include`` (already in the unit box) replaces the design
    point nearest to it, so the size stays ``size`` (or grows to the number
    of user points) and the space filling is disturbed as little as possible.
    ``kind`` names a design in :data:`~.registry.DESIGNS`; Latin hypercubes
    are chosen by maximin, Sobol sequences are used as drawn.

    Points ``covered`` already (simulated before and reused) count towards the size: only
    the points still missing are designed, by :func:`fill_gaps` around the covered and
    included ones instead of ``kind``.
    """
    entry = DESIGNS[kind]
    generate: Design = entry.load()
    include = (
        np.empty((0, dimension)) if include is None else np.atleast_2d(np.asarray(include, float))
    )
    if covered is not None and len(covered):
        missing = max(size - len(covered) - len(include), 0)
        return np.vstack(
            [include, fill_gaps(np.vstack([covered, include]), missing, dimension, rng)]
        )
    generated_size = max(size, 1)
    design = (
        generate(generated_size, dimension, rng)
        if not entry.maximin
        else maximin_design(generate, generated_size, dimension, rng, tries)
    )
    keep = np.ones(len(design), dtype=bool)
    for point in include:
        distances = np.linalg.norm(design - point, axis=1)
        distances[~keep] = np.inf
        if np.isfinite(distances).any():
            keep[int(np.argmin(distances))] = False
    return np.vstack([include, design[keep]])
