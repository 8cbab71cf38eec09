"""The backend's upgrade check answers every header combination with a 4xx, never a 500."""

from __future__ import annotations

import pytest
from rpc_backend import BackendProcess
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect


@pytest.mark.parametrize(("extra", "status"), [
    ([("Authorization", "same"), ("Authorization", "same")], 401),
    ([("Authorization", "same"), ("Authorization", "Bearer wrong")], 401),
    ([("Authorization", "Bearer wrong"), ("Authorization", "same")], 401),
    ([("Authorization", "same"), ("Origin", "http://a.example"), ("Origin", "http://b.example")], 403),
])
def test_repeated_auth_or_origin_headers_are_refused_not_a_server_error(
        backend: BackendProcess, extra: list[tuple[str, str]], status: int) -> None:
    """Two `Authorization` headers (even both carrying the token) answer 401, two `Origin` headers 403;
    they used to answer 500 (`headers.get` raises on a repeated header). The backend serves on."""
    token = f"Bearer {backend.token}"
    headers = [(name, token if value == "same" else value) for name, value in extra]
    with pytest.raises(InvalidStatus) as info:
        connect(backend.url, additional_headers=headers, open_timeout=10)
    assert info.value.response.status_code == status
    client = backend.client()
    assert client.call("ping")["version"]
    client.close()
