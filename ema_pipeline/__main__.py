"""``python -m ema_pipeline ...``: the command-line interface (:func:`ema_pipeline.cli.run`)."""

import sys

from ema_pipeline.cli import run

sys.exit(run())
