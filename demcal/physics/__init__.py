"""Granular-material helpers shared by scenes and engines, whatever the scene.

- ``psd``: particle size distributions (truncated lognormal);
- ``sieve``: GGS, RRSB and LOGN fitted to sieve data (``demcal psd fit``);
- ``particles``: the spheres and time step of one simulation, the same for a
  seed on every engine;
- ``measure``: bulk measurements from particle positions (surface profiles,
  bulk density, slope and heap angles).
"""
