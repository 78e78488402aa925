"""The refinement: the kept poles fitted locally, and LSFD.

:mod:`.refine` (variable-projection refinement of the poles with their
covariance, the band-sensitivity term), :mod:`.local_band` (the local
problem of one mode), :mod:`.local_fits` (local screens and fits of single
modes), :mod:`.lsfd` (residues, shapes and fit indicators) and
:mod:`.uncertainty` (the noise and covariance model). The modules load on
import of their own names only (this package imports nothing).
"""
