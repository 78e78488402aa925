"""The diagrams: the candidates of the identification.

:mod:`.plscf` (the pLSCF poles of every model order), :mod:`.stabilization`
(the stability flags between orders), :mod:`.order_search` (the adaptive
order search of a band: diagrams of growing order, their trajectories and
candidates), :mod:`.narrower_searches` (the searches of a wide band's lowest
part and of a dense band's windows: alternates, band support) and
:mod:`.resources` (the highest order the data support, the memory estimate).
The modules load on import of their own names only (this package imports
nothing).
"""
