"""The ``ema-pipeline`` parser for the command-line reference (sphinx-argparse).

It is :func:`ema_pipeline.cli.parser.build_parser` itself; only descriptions
written for ``RawDescriptionHelpFormatter`` (an indented list after a line ending
in ``:``, e.g. the columns of ``<stem>_modes.csv``) get a reStructuredText
literal-block marker, so that they render as preformatted text.
"""

from __future__ import annotations

import argparse
import re

from ema_pipeline.cli.parser import build_parser


def _literal_blocks(text: str) -> str:
    return re.sub(r":\n(?=[ \t]+\S)", "::\n\n", text)


def docs_parser() -> argparse.ArgumentParser:
    parser = build_parser()
    for action in parser._actions:  # noqa: SLF001  (argparse keeps subparsers here)
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for sub in action.choices.values():
                if sub.formatter_class is argparse.RawDescriptionHelpFormatter and sub.description:
                    sub.description = _literal_blocks(sub.description)
    return parser
