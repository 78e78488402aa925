"""A live roving-hammer impact test in the browser (``ema-pipeline live``).

Modules: :mod:`~ema_pipeline.live.device` (the acquisition interface and the
replay device), :mod:`~ema_pipeline.live.simulate` (a virtual structure with a
virtual hammer), :mod:`~ema_pipeline.live.soundcard` (a sound card through the
optional sounddevice package), :mod:`~ema_pipeline.live.judge` (the hits judged on the stream,
the running FRF), :mod:`~ema_pipeline.live.engine` (the test: journal, choices,
identification in a worker), :mod:`~ema_pipeline.live.server` (the local web
server) and :mod:`~ema_pipeline.live.app` (what the command runs). The page is
:mod:`ema_pipeline.report.live_page`; the session folder's layout
:mod:`ema_pipeline.io.live_session`. Importing this package loads neither
starlette nor uvicorn (the ``live`` extra): the server imports them when started.
"""
