"""The selection: which candidates are modes.

:mod:`.trajectories` (pole trajectories across the orders and the
automatic choice among them, the expected candidates), :mod:`.acceptance`
(the final tests over all FRFs), :mod:`.partners` (close modes hidden in a
kept resonance), :mod:`.pairs` (two close poles judged with few channels),
:mod:`.residual_search`
(modes the diagrams missed, from the residual of the kept modes' fit),
:mod:`.edge_poles` (resonances at the band's edges, kept in their
neighbours' fits and not reported), :mod:`.expect` (guesses answered or not
found), :mod:`.picks` (modes picked by hand) and :mod:`.not_kept` (resonances
the FRFs show that no mode was kept for). The modules load on import of
their own names only (this package imports nothing).
"""
