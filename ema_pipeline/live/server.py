"""The local web server of a live test (starlette on uvicorn).

It serves one page, ``/<token>/``, and one WebSocket, ``/<token>/ws``: the
test's state is pushed over it when it changes, and the page's commands
(accept, reject, undo, next, finish, strike) come back over it. The token is
random (:func:`secrets.token_urlsafe`); any other address is refused with 403,
and so is a WebSocket whose ``Origin`` is not the page's own. It listens on
127.0.0.1 unless another host is given.
"""

from __future__ import annotations

import asyncio
import json
import secrets
import socket
from collections.abc import Callable
from typing import Any

from ema_pipeline.live.engine import LiveTest
from ema_pipeline.report.live_page import live_page_html, plan_layout

__all__ = ["LiveServer", "live_app"]

#: Seconds between two looks at the test's state (a change is pushed at once after).
PUSH_EVERY_S = 0.03


def live_app(test: LiveTest, token: str, title: str) -> Any:
    """The starlette application of a live test (module docstring)."""
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import HTMLResponse, PlainTextResponse, Response
    from starlette.routing import Route, WebSocketRoute
    from starlette.websockets import WebSocket

    channels = [(c.name, c.quantity, c.dof.label() if c.dof else "")
                for c in test.points[0].plan.channels] if test.points else []
    page = live_page_html(f"/{token}/ws", title, channels, plan_layout(test.geometry))

    async def index(request: Request) -> Response:
        if request.path_params.get("token") != token:
            return PlainTextResponse("forbidden: this address needs the session's token\n",
                                     status_code=403)
        return HTMLResponse(page, headers={"Cache-Control": "no-store"})

    async def refuse(request: Request) -> Response:
        return PlainTextResponse("forbidden: this address needs the session's token\n",
                                 status_code=403)

    async def stream(ws: WebSocket) -> None:
        origin = ws.headers.get("origin")
        host = ws.headers.get("host", "")
        if ws.path_params.get("token") != token or (
            origin is not None and origin not in (f"http://{host}", f"https://{host}")
        ):
            await ws.close(code=1008)
            return
        await ws.accept()
        actions: dict[str, Callable[..., None]] = {
            "accept": lambda m: test.decide("accept", m.get("hit")),
            "reject": lambda m: test.decide("reject", m.get("hit")),
            "undo": lambda m: test.decide("undo"),
            "next": lambda m: test.next_point(),
            "finish": lambda m: test.finish(),
            "strike": lambda m: test.strike(),
        }

        async def receive() -> None:
            while True:
                msg = json.loads(await ws.receive_text())
                act = actions.get(str(msg.get("action")))
                if act is not None:
                    await asyncio.to_thread(act, msg)

        async def push() -> None:
            seen = -1
            while True:
                if test.version != seen:
                    state = await asyncio.to_thread(test.snapshot)
                    seen = state["version"]
                    await ws.send_text(json.dumps(state, allow_nan=False))
                await asyncio.sleep(PUSH_EVERY_S)

        tasks = [asyncio.create_task(receive()), asyncio.create_task(push())]
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            for t in done:  # retrieved: the page closed (WebSocketDisconnect) or sent nonsense
                t.exception()
        finally:
            for t in tasks:
                t.cancel()

    routes = [Route("/{token}/", index), WebSocketRoute("/{token}/ws", stream),
              Route("/{path:path}", refuse)]
    return Starlette(routes=routes)


class LiveServer:
    """uvicorn serving :func:`live_app` on ``host``:``port`` (0: a free port);
    :attr:`url` is the page's address with its token."""

    def __init__(self, test: LiveTest, title: str, host: str = "127.0.0.1",
                 port: int = 0) -> None:
        import uvicorn

        self.token = secrets.token_urlsafe(18)
        self.sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind((host, port))
        self.sock.listen(64)  # connections wait from now on, before uvicorn serves
        self.host, self.port = host, int(self.sock.getsockname()[1])
        config = uvicorn.Config(live_app(test, self.token, title), log_level="warning",
                                ws="websockets", lifespan="off")
        self.server = uvicorn.Server(config)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/{self.token}/"

    def serve(self) -> None:
        """Serve until interrupted (Ctrl-C) or :meth:`stop`."""
        self.server.run(sockets=[self.sock])

    def stop(self) -> None:
        self.server.should_exit = True
