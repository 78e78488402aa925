"""The script of the interactive stabilization diagram (:mod:`.stab_diagram`),
the file ``report/js/stab_diagram.js`` (:mod:`.scripts`).

It draws the diagram's poles from the page's JSON (``script.stab-poles``)
as ``text.pole`` elements, their stability symbol in its colour; redraws
the frequency axis, the sum FRF and the synthesis (:mod:`.synthesis_view`)
at every zoom and pan; previews a pole on a click; picks or unpicks the
previewed pole on its own act (the preview's ``[data-pick-toggle]`` button
or the key :data:`PICK_KEY`); and writes the picks file. The frequency
ticks take the first of the page's steps (``steps``,
:func:`.svg.nice_steps`) at least the range over ``parts``: the step of
:func:`.svg.nice_step`, the one home of that choice.
"""

from __future__ import annotations

from ema_pipeline.report.scripts import page_script
from ema_pipeline.report.synthesis_view import SYNTHESIS_JS

__all__ = ["CURVE_LEVELS", "PICK_KEY", "STAB_CALL", "STAB_SCRIPT"]

#: The levels of the overlay's characters (15 bits, from synthesis_view.CODE_0).
CURVE_LEVELS = 32767
#: The key that picks or unpicks the previewed pole (either case).
PICK_KEY = "p"

#: The code: defines ``emaStabDiagram(root)``, which brings the diagram
#: ``root`` (its ``.stabd`` element) to life. A page holds it once (in its
#: first diagram) and calls it in every diagram (:data:`STAB_CALL`).
STAB_SCRIPT = page_script("stab_diagram.js", SYNTHESIS_JS=SYNTHESIS_JS,
                          CURVE_LEVELS=CURVE_LEVELS, PICK_KEY=PICK_KEY)
#: The call in each diagram's own script.
STAB_CALL = page_script("stab_call.js")
