"""Initial experimental designs in the unit box [0, 1]^d.

Samuelsson (2023), section 2.2.2.1: a Latin hypercube design (LHD) puts one
point in each of n equal-probability slices of every axis; the symmetric
variant of Ye et al. (SLHD) pairs every row with its mirror image
n+1-x; among several random designs the maximin criterion keeps the one
whose closest pair of points is farthest apart. Rackl & Hanley (2017) start
from a plain LHS. Sobol sequences come from scipy.stats.qmc.
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
    candidates = sobol_sequence(1024, dimension, rng)
    nearest = cdist(candidates, np.asarray(covered, float)).min(axis=1)
    chosen = []
    for _ in range(size):
        pick = candidates[int(np.argmax(nearest))]
        chosen.append(pick)
        nearest = np.minimum(nearest, np.linalg.norm(candidates - pick, axis=1))
    return np.array(chosen).reshape(size, dimension)


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
