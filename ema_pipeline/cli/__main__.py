"""``python -m ema_pipeline.cli ...``: the command line (:func:`ema_pipeline.cli.main`)."""

import sys

from ema_pipeline.cli import main

sys.exit(main())
