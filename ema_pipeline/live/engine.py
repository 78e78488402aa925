"""A live roving-hammer test: the device read in a thread, every block journaled
before it is used, each hit judged as its record completes, the choices by hand,
the points so far identified in a worker process, the page's state.

The test runs on a :class:`~ema_pipeline.live.device.Device` and a
:class:`~ema_pipeline.io.live_session.SessionFolder`. A point is *done* when the
next point is asked for (or at the finish): its recording is written as a WAV,
``channels.csv`` and ``hits.toml`` are rewritten, and the points done so far are
identified in the worker (:func:`identify_session`: what ``frf --channels
DIR/channels.csv --hits DIR/hits.toml`` and ``identify --band`` compute), never
in the acquisition's thread. Started again on the same folder, the test resumes:
the points done come back with their hits, and the point in progress continues
from the end of its journal.
"""

from __future__ import annotations

import concurrent.futures as cf
import threading
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ema_pipeline.data import ConfigError, EMAError, Geometry
from ema_pipeline.io.live_session import SessionFolder
from ema_pipeline.live.device import Device, PlanPoint
from ema_pipeline.live.judge import LiveHit, PointStream
from ema_pipeline.pipeline.frf import FRFSettings
from ema_pipeline.runner import ProcessPool

__all__ = ["LiveTest", "identification_pool", "identify_session"]

#: Seconds between two redraws of the live trace.
TRACE_EVERY_S = 0.25


def identification_pool() -> ProcessPool:
    """The one worker process that identifies the points so far: the runner's pool
    started by a fork server (a fresh interpreter: it shares no thread or lock with
    the server), BLAS threads as the runner sets them, ended when this process
    dies (:class:`ema_pipeline.runner.ProcessPool`)."""
    return ProcessPool(1, start="server", preload=("ema_pipeline.live.engine",))


def identify_session(folder: str, band_hz: tuple[float, float] | None = None) -> dict[str, Any]:
    """Identify the points done of a session folder: the FRFs of ``frf --channels
    DIR/channels.csv --hits DIR/hits.toml`` (default settings), then ``identify``
    (``--band``); the modes as plain numbers (``error``: why none).

    Examples
    --------
    >>> import tempfile
    >>> out = identify_session(tempfile.mkdtemp(), None)
    >>> out["n_points"], out["error"].endswith("no such file")
    (0, True)
    """
    from ema_pipeline.identification import check_input, identify
    from ema_pipeline.identification.options import IdentificationOptions
    from ema_pipeline.io.hit_choice import read_hit_choice
    from ema_pipeline.pipeline.roving import sheet_frf

    root = Path(folder)
    try:
        result = sheet_frf(root / "channels.csv", FRFSettings(),
                           chosen=read_hit_choice(root / "hits.toml"))
        checked = check_input(result.frf, IdentificationOptions(band_hz=band_hz))
        modes = identify(checked).modes
    except (EMAError, ValueError, np.linalg.LinAlgError) as exc:
        return {"error": str(exc), "n_points": 0}
    shapes = modes.shapes if modes.shapes is not None else np.zeros((0, modes.n_modes))
    return {"error": "", "n_points": len(result.points), "fn_hz": modes.fn_hz.tolist(),
            "zeta": modes.zeta.tolist(), "shapes_re": shapes.real.tolist(),
            "shapes_im": shapes.imag.tolist(),
            "dofs": [[int(d.node), int(d.direction)] for d in modes.dofs]}


def _finite(x: float) -> float | None:
    """``x``, or None (JSON null) when not finite: the page's JSON has no NaN."""
    return float(x) if np.isfinite(x) else None


@dataclass
class PointState:
    """One point of the plan: ``state`` todo / current / done, its stream (while
    current or resumed), its hits, and the undo stack of choices by hand."""

    plan: PlanPoint
    state: str = "todo"
    hits: list[LiveHit] = field(default_factory=list)
    undo: list[tuple[int, bool]] = field(default_factory=list)
    accepted_numbers: list[int] = field(default_factory=list)

    @property
    def n_accepted(self) -> int:
        return sum(h.accepted for h in self.hits)


class LiveTest:
    """The live test (module docstring); :meth:`start` runs it, :meth:`close` ends it."""

    def __init__(self, device: Device, session: SessionFolder, *,
                 settings: FRFSettings | None = None, band_hz: tuple[float, float] | None = None,
                 geometry: Geometry | None = None, identify_points: bool = True) -> None:
        self.device = device
        self.session = session
        self.settings = settings or FRFSettings()
        self.band_hz = band_hz
        self.geometry = geometry
        self.fs = device.sample_rate_hz
        self.points = [PointState(p) for p in device.plan]
        self.current = 0  # index into points; len(points): none left
        self.stream: PointStream | None = None
        self.record_n: int | None = None
        self.lock = threading.RLock()
        self.version = 0
        self.messages: list[str] = []
        self.finished = False
        self.final = False
        self.identifying = False
        self.modes: dict[str, Any] = {}
        self.identify_points = identify_points
        self._pool: ProcessPool | None = None
        self._job = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._trace_at = 0.0
        self._final_judged = False
        self.frf_figure = ""
        self.trace_figure = ""
        self.shapes_html = ""
        self.trigger_n = 0.0

    # -- start, resume, stop ------------------------------------------------
    def _plan_json(self) -> dict[str, Any]:
        return {"sample_rate_hz": self.fs, "points": [
            {"number": p.plan.number, "label": p.plan.label,
             "channels": [[c.name, c.quantity, c.dof.node if c.dof else 0,
                           c.dof.direction if c.dof else 0] for c in p.plan.channels]}
            for p in self.points]}

    def start(self) -> None:
        """Lock the folder, resume what it holds, start the device's thread."""
        self.session.lock()
        plan = self._plan_json()
        old = self.session.read_plan()
        if old is not None and old != plan:
            self.session.unlock()
            raise ConfigError(f"{self.session.folder}: holds a session of another test (its "
                           "session.json differs: another sheet, model or sample rate); give "
                           "another --session")
        self.session.write_plan(plan)
        self._resume()
        self._thread = threading.Thread(target=self._run, name="live-acquisition", daemon=True)
        self._thread.start()

    def _resume(self) -> None:
        for k, p in enumerate(self.points):
            entry = self.session.read_journal(p.plan.number)
            if entry is None:
                break
            p.hits = [LiveHit.from_dict(h) for h in entry.get("hits", [])]
            p.accepted_numbers = list(entry.get("accepted_numbers", []))
            self.record_n = entry.get("record_n") or self.record_n
            if entry.get("done"):
                p.state = "done"
                continue
            self.current = k
            break
        else:
            self.current = len(self.points)
        if any(p.state == "done" for p in self.points):
            self.messages.append(f"resumed: {sum(p.state == 'done' for p in self.points)} "
                                 "point(s) done")
            self._submit_identification()
        if self.current < len(self.points):
            self._begin(self.current, resume=True)
        else:
            self.finished = True
            self._submit_identification(final=True)

    def _begin(self, index: int, resume: bool = False) -> None:
        p = self.points[index]
        p.state = "current"
        self.current = index
        n_ch = len(p.plan.channels)
        stream = PointStream(p.plan.channels, self.fs, self.settings, self.record_n,
                             name=f"point {p.plan.label}")
        first = 0
        if resume:
            data = self.session.read_raw(p.plan.number, n_ch)
            self.session.truncate_raw(p.plan.number, data.shape[1], n_ch)
            if data.shape[1]:
                stream.append(data)
                stream.hits = list(p.hits)  # the verdicts and choices as journaled
                stream.judge()  # and the hits completed since
                first = data.shape[1]
        p.hits = stream.hits
        self.stream = stream
        self._final_judged = False
        self.device.start(p.plan.number, first)
        self._update_frf()
        self._journal(p)

    def close(self) -> None:
        """Stop the thread, the device and the worker; release the lock."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self.device.stop()
        if self._pool is not None:
            self._pool.close(abort=True)
        self.session.unlock()

    # -- the acquisition thread ---------------------------------------------
    def _run(self) -> None:
        """The acquisition thread: a failure (the device, a full disk) stops it with a
        message on the page; the journal holds everything up to it."""
        try:
            self._acquire()
        except (EMAError, OSError, ValueError) as exc:
            with self.lock:
                self.messages.append(f"acquisition stopped: {exc}")
                self._changed()

    def _acquire(self) -> None:
        while not self._stop.is_set():
            block = self.device.read(0.05)
            with self.lock:
                if self.stream is None or self.finished:
                    continue
                p = self.points[self.current]
                if block is not None:
                    data = np.asarray(block.data, dtype=np.float32)
                    self.session.append(p.plan.number, data)  # journaled before use
                    self.stream.append(data, block.lost, block.wall_s or time.time())
                    if block.lost:
                        self.messages.append(f"point {p.plan.label}: {block.lost} samples "
                                             f"lost before {block.first_sample / self.fs:.3f} s")
                    self._maybe_trace()
                if self.stream.due():
                    self._judge(p, final=False)
                if not self.device.streaming() and not self._final_judged:
                    self._judge(p, final=True)
                    self._final_judged = True
                    self._changed()

    def _judge(self, p: PointState, final: bool) -> None:
        assert self.stream is not None
        new = self.stream.judge(final)
        if self.stream.record_n is not None:
            self.record_n = self.record_n or self.stream.record_n
        if new:
            p.hits = self.stream.hits
            self._update_frf()
            self._journal(p)
            self._changed()

    def _maybe_trace(self) -> None:
        now = time.monotonic()
        if now - self._trace_at < TRACE_EVERY_S:
            return
        self._trace_at = now
        from ema_pipeline.report.live_page import trace_figure

        assert self.stream is not None
        stream = self.stream
        span = int(2.0 * self.fs)
        data = stream.data[:, max(0, stream.n - span):]
        t0 = max(0, stream.n - span) / self.fs
        self.trigger_n = stream.trigger_n
        self.trace_figure = trace_figure(data, self.fs, t0, self.trigger_n)
        self._changed()

    def _update_frf(self) -> None:
        from ema_pipeline.report.live_page import running_frf_figure

        assert self.stream is not None
        frf = self.stream.running_frf()
        label = self.points[self.current].plan.label
        self.frf_figure = running_frf_figure(frf, f"point {label}")

    def _journal(self, p: PointState) -> None:
        self.session.write_journal(p.plan.number, {
            "label": p.plan.label, "done": p.state == "done",
            "hits": [h.as_dict() for h in p.hits], "accepted_numbers": p.accepted_numbers,
            "record_n": self.record_n})

    def _changed(self) -> None:
        self.version += 1

    # -- the engineer's commands ---------------------------------------------
    def decide(self, action: str, number: int | None = None) -> None:
        """``accept`` / ``reject`` hit ``number`` (default: the last), or ``undo``
        the last choice (none left: reject the last accepted hit)."""
        with self.lock:
            if self.stream is None or self.finished:
                return
            p = self.points[self.current]
            if not p.hits:
                return
            if action == "undo":
                if p.undo:
                    k, was = p.undo.pop()
                    p.hits[k - 1].accepted = was
                else:
                    last = [h for h in p.hits if h.accepted]
                    if not last:
                        return
                    last[-1].accepted = False
            else:
                hit = p.hits[(number or len(p.hits)) - 1]
                p.undo.append((hit.number, hit.accepted))
                hit.accepted = action == "accept"
            self._update_frf()
            self._journal(p)
            self._changed()

    def strike(self, **options: Any) -> None:
        """Strike the current point (a device with a virtual hammer)."""
        hammer = getattr(self.device, "strike", None)
        if hammer is not None and not self.finished:
            hammer(**options)

    def next_point(self) -> None:
        """The current point is done; the next one begins."""
        with self.lock:
            if self.finished or self.stream is None:
                return
            self._complete_current()
            if self.current + 1 < len(self.points):
                self._begin(self.current + 1)
            else:
                self.current = len(self.points)
                self.stream = None
            self._changed()

    def finish(self) -> None:
        """The current point is done (when it has hits), and the final identification."""
        with self.lock:
            if self.finished:
                return
            if self.stream is not None:
                self._complete_current()
            self.stream = None
            self.finished = True
            self.device.stop()
            self._submit_identification(final=True)
            self._changed()

    def _complete_current(self) -> None:
        assert self.stream is not None
        p = self.points[self.current]
        self.device.stop()
        if not self._final_judged:
            self._judge(p, final=True)
        self.session.close_raw(p.plan.number)
        p.hits = self.stream.hits
        if self.stream.n:
            p.accepted_numbers = self.stream.accepted_numbers()
            self.session.write_wav(p.plan.number, self.stream.data, self.fs)
        p.state = "done"
        self._journal(p)
        self._write_summaries()
        self._submit_identification()

    def _write_summaries(self) -> None:
        done = [p for p in self.points if p.state == "done" and p.accepted_numbers]
        if not done:
            return
        self.session.write_sheet([
            (p.plan.number, [("force" if k == 0 else "response", c.quantity,
                              c.dof.node if c.dof else 0, c.dof.direction if c.dof else 0)
                             for k, c in enumerate(p.plan.channels)]) for p in done])
        self.session.write_hits({p.plan.number: p.accepted_numbers for p in done})

    # -- identification in the worker -----------------------------------------
    def _submit_identification(self, final: bool = False) -> None:
        if not (self.identify_points or final):
            return
        if not any(p.state == "done" and p.accepted_numbers for p in self.points):
            if final:
                self.final = True
            return
        if self._pool is None:
            self._pool = identification_pool()
        self._job += 1
        job = self._job
        self.identifying = True
        work = partial(identify_session, band_hz=self.band_hz)
        try:
            future = self._pool.submit(work, str(self.session.folder))
        except cf.process.BrokenProcessPool:  # the worker died (killed): a new one
            self._pool.restart()
            future = self._pool.submit(work, str(self.session.folder))
        future.add_done_callback(lambda f: self._identified(f, job, final))

    def _identified(self, future: cf.Future, job: int, final: bool) -> None:
        try:
            out = future.result()
        except Exception as exc:  # noqa: BLE001 - the worker's failure, shown on the page
            out = {"error": f"identification failed: {type(exc).__name__}: {exc}",
                   "n_points": 0}
        with self.lock:
            if job != self._job:
                return
            self.identifying = False
            self.final = self.final or final
            self.modes = out
            self.shapes_html = self._shapes(out)
            self._changed()

    def _shapes(self, out: dict[str, Any]) -> str:
        if out.get("error") or self.geometry is None or not out.get("fn_hz"):
            return ""
        from ema_pipeline.data import DOF
        from ema_pipeline.report.shape_views import ModeSet, shape_views_html

        shapes = np.asarray(out["shapes_re"]) + 1j * np.asarray(out["shapes_im"])
        dofs = tuple(DOF(n, d) for n, d in out["dofs"])
        if shapes.size == 0 or len(dofs) < 3:
            return ""
        modes = ModeSet(np.asarray(out["fn_hz"]), np.asarray(out["zeta"]), shapes, dofs)
        try:
            return shape_views_html(self.geometry, modes)
        except (EMAError, ValueError, KeyError):
            return ""

    # -- the page's state -----------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """What the page shows (plain JSON)."""
        with self.lock:
            cur = self.points[self.current] if self.current < len(self.points) else None
            hits = cur.hits if (cur is not None and not self.finished) else []
            return {
                "version": self.version,
                "streaming": bool(self.stream is not None and not self._final_judged),
                "finished": self.finished, "final": self.final,
                "identifying": self.identifying,
                "current": cur.plan.label if cur is not None and not self.finished else "",
                "channels": [[c.name, c.quantity, c.dof.label() if c.dof else ""]
                             for c in (cur or self.points[-1]).plan.channels],
                "points": [{"number": p.plan.number, "label": p.plan.label,
                            "node": p.plan.node, "state": p.state,
                            "accepted": p.n_accepted} for p in self.points],
                "hits": [{"number": h.number, "time_s": round(h.time_s, 4),
                          "peak_n": round(h.peak_n, 3),
                          "status": "accepted" if h.accepted else "rejected",
                          "reasons": list(h.reasons), "by_hand": h.accepted != h.auto,
                          "record_end_ms": round(1000 * h.record_end_wall, 1)}
                         for h in hits],
                "frf_figure": self.frf_figure if cur is not None else "",
                "trace_figure": self.trace_figure if cur is not None else "",
                "modes": ([{"n": k + 1, "fn_hz": _finite(f), "zeta": _finite(z)}
                           for k, (f, z) in enumerate(zip(self.modes.get("fn_hz", []),
                                                          self.modes.get("zeta", []),
                                                          strict=True))]),
                "modes_points": self.modes.get("n_points", 0),
                "modes_error": self.modes.get("error", ""),
                "shapes_html": self.shapes_html,
                "messages": self.messages[-5:],
                "virtual_hammer": hasattr(self.device, "strike"),
            }
