"""Orchestration: the whole study (:mod:`.study`), one FRF file through
identification (:mod:`.single`), and folders of files in batch (:mod:`.batch`)."""
