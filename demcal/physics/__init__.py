"""Granular-material helpers shared by scenes and engines, whatever the scene.

- ``catalogue``: the DEM parameters demcal knows, with their SI units and ranges;
- ``contact``: contact-model conversions;
- ``psd``: particle size distributions (truncated lognormal);
- ``sieve``: GGS, RRSB and LOGN fitted to sieve data (``demcal psd fit``);
- ``timestep``: the Rayleigh time step (Rackl & Hanley 2017, eq. 1) and its cost term;
- ``measure``: bulk measurements from particle positions (surface profiles,
  bulk density, slope and heap angles).

The spheres and time step of one simulation are ``demcal.engines.particles``.
"""
