"""The pages' JavaScript: the ``.js`` files of ``ema_pipeline/report/js``.

The scripts ship as package data and are read with :mod:`importlib.resources`
(so they are found in a wheel as in the checkout). A script's numbers that
have their home in Python (the synthesis' character levels, the shape views'
size, the pick key) stand in its file as ``__NAME__`` tokens, filled by
:func:`page_script`. The files are the pages' bytes: a file starts or ends
with a newline only where the page's script does.

Files: ``stab_diagram.js`` (the interactive stabilization diagram,
:mod:`.stab_script`; it holds ``synthesis.js``, the page's refit of the
picked poles, :mod:`.synthesis_view`, at its ``__SYNTHESIS_JS__`` line),
``stab_call.js`` (the call in each diagram), ``shape_views.js`` (the animated
mode shapes, :mod:`.shape_views`) and ``hit_choice.js`` (the hit page's choice
of hits, :mod:`.hit_choice_view`).
"""

from __future__ import annotations

import re
from importlib import resources

__all__ = ["page_script"]

_TOKEN = re.compile(r"__[A-Z][A-Z0-9_]*__")


def page_script(name: str, **values: object) -> str:
    """The text of the script file ``name`` with its tokens filled.

    Parameters
    ----------
    name : str
        File name in ``ema_pipeline/report/js`` (``"hit_choice.js"``).
    **values
        ``KEY=value`` replaces every ``__KEY__`` of the file by ``str(value)``.

    Returns
    -------
    str
        The script as the page carries it.

    Raises
    ------
    ValueError
        A value without its token in the file, or a token left unfilled.

    Examples
    --------
    >>> page_script("stab_call.js").startswith("emaStabDiagram(")
    True
    >>> "var W=300,H=170," in page_script("shape_views.js", VIEW_W=300, VIEW_H=170)
    True
    """
    text = resources.files("ema_pipeline.report").joinpath("js").joinpath(name) \
        .read_bytes().decode("utf-8")
    for key, value in values.items():
        token = f"__{key}__"
        if token not in text:
            raise ValueError(f"report/js/{name}: no {token} to fill")
        text = text.replace(token, str(value))
    left = _TOKEN.search(text)
    if left:
        raise ValueError(f"report/js/{name}: {left.group()} is not filled")
    return text
