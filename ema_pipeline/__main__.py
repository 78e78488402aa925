"""``python -m ema_pipeline ...``: the command-line interface (:func:`ema_pipeline.cli.main`)."""

import sys

from ema_pipeline.cli import main

sys.exit(main())
