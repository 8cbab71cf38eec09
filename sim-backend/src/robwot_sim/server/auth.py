"""Who may connect: the upgrade check of the backend's WebSocket server."""

from __future__ import annotations

import hmac
from collections.abc import Callable
from http import HTTPStatus

from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response


def owner_check(token: str) -> Callable[[ServerConnection, Request], Response | None]:
    """The upgrade check: only a client presenting ``Authorization: Bearer <token>`` gets a connection.

    An upgrade carrying an ``Origin`` header comes from a web page (browsers always send one, scripts and
    the servient never do) and is refused before the token is even looked at. Exactly one
    ``Authorization`` header: several are refused (401) whatever they hold.
    """
    expected = f"Bearer {token}".encode()

    def check(conn: ServerConnection, request: Request) -> Response | None:
        # get_all: `get` raises on a repeated header, which websockets answers with a 500
        if request.headers.get_all("Origin"):
            return conn.respond(HTTPStatus.FORBIDDEN, "browser origins may not connect to the backend\n")
        given = request.headers.get_all("Authorization")
        if len(given) != 1 or not hmac.compare_digest(given[0].encode(), expected):
            return conn.respond(HTTPStatus.UNAUTHORIZED, "the backend's token is required "
                                "(Authorization: Bearer <ROBWOT_BACKEND_TOKEN>)\n")
        return None

    return check
