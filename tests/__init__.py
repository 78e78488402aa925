"""The test suite of ema-pipeline, a package so that its helper modules
(``tests.hardcases``, ``tests.impact_recordings``, ...) import as ``tests.NAME``
from the repository's root."""
