"""``python -m ema_pipeline.cli ...``: the command line (:func:`ema_pipeline.cli.run`)."""

import sys

from ema_pipeline.cli import run

sys.exit(run())
