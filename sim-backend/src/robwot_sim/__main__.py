"""`python -m robwot_sim serve [--host 127.0.0.1] [--port 0] [--max-message BYTES]`.

Stdout carries exactly one line once the server listens, `{"event":"ready","port":N}` (plus `"token"`
when the server made its own token, see below): everything else (logs, Bullet's own printf output) is
redirected to stderr. SIGTERM/SIGINT stop the server cleanly.

Every connection must present the backend's token (`Authorization: Bearer <token>`). The token comes
from the environment variable `ROBWOT_BACKEND_TOKEN` (how launchers hand it over: never on the command
line, which every local user can read); without it a random one is made and printed in the ready line
(`{"event":"ready","port":N,"token":"..."}`), which only the process that started the server reads.
"""

from __future__ import annotations

import argparse
import faulthandler
import json
import logging
import os
import secrets
import sys

from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m robwot_sim", description="RobWoT simulation backend")
    sub = parser.add_subparsers(dest="command", required=True)
    serve = sub.add_parser(
        "serve", help="serve JSON-RPC 2.0 over WebSocket",
        epilog="Only the owner is served: every connection must send 'Authorization: Bearer <token>'. "
               "The token is read from the environment variable ROBWOT_BACKEND_TOKEN (never pass it on "
               "the command line); without it a random token is made and printed in the ready line "
               '{"event":"ready","port":N,"token":"..."}. Upgrades carrying an Origin header (browsers) '
               "are refused.")
    serve.add_argument("--host", default="127.0.0.1", help="interface to bind (default: loopback)")
    serve.add_argument("--port", type=int, default=0, help="TCP port, 0 = any free port (default)")
    serve.add_argument("--max-message", type=int, default=DEFAULT_MAX_MESSAGE_BYTES,
                       help=f"largest accepted message in bytes (default {DEFAULT_MAX_MESSAGE_BYTES})")
    serve.add_argument("--log-level", default="WARNING", help="stderr log level (default WARNING)")
    serve.add_argument("--exit-on-stdin-eof", action="store_true",
                       help="stop when stdin is closed (used by launchers to tie our life to theirs)")
    serve.add_argument("--warm-workers", type=_worker_count, metavar="N",
                       help="start the labelling pool (N worker processes, 0: one per core) while the server "
                            "starts, for a client that will generate a workspace (robwot generate)")
    sub.add_parser(
        "compile", help="compile the backend's bytecode and its kernels into numba's disk cache",
        description="Compiles the backend's Python bytecode and the path-check and labelling kernels once "
                    "per machine (npm install runs it): a backend that needs them then loads them from "
                    "the cache instead of compiling them on a thread of its own while it serves. Without "
                    "numba, or if they cannot compile, every check runs on Bullet alone (said here; exit "
                    "code 0).")
    return parser


def _worker_count(text: str) -> int:
    from robwot_sim.limits import value_schema

    most = int(value_schema("Workers")["maximum"])
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not 0 <= n <= most:
        raise argparse.ArgumentTypeError(f"{n} is not within 0..{most}")
    return n


def _compile() -> int:
    import compileall
    from pathlib import Path

    from robwot_sim.sim.kernels import KERNELS_WAIT, kernels_ready

    # The package's bytecode too: a Python told not to write it (PYTHONDONTWRITEBYTECODE, as on CI machines)
    # would compile every module from source at each backend start. A stale file is recompiled on import.
    compileall.compile_dir(str(Path(__file__).parent), quiet=1)
    ok = kernels_ready(timeout=KERNELS_WAIT)
    print("robwot: the outer bounds' kernels are compiled" if ok else
          "robwot: the outer bounds' kernels are not available: every check runs on Bullet alone",
          file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "compile":
        return _compile()
    # Keep the real stdout for the ready line only; send fd 1 (C printf from Bullet) to stderr.
    sys.stdout.flush()
    ready_fd = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    # a crash in native code (PyBullet, CoACD) leaves every thread's Python stack on stderr, which the
    # launcher hands to whoever sees the connection drop
    faulthandler.enable()
    logging.basicConfig(level=args.log_level.upper(), stream=sys.stderr,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    # The forkserver imports the simulation and loads the kernels beside our imports, so it starts before
    # anything heavy is imported here (asyncio, the server, numpy: the packages' __init__ import nothing).
    if args.warm_workers is not None:
        from robwot_sim.workspace.pool import warm_up

        warm_up(args.warm_workers or None)
    import asyncio

    from robwot_sim.server.app import run_server

    given = os.environ.pop("ROBWOT_BACKEND_TOKEN", "")
    token = given or secrets.token_urlsafe(32)

    def ready(port: int) -> None:
        doc: dict[str, object] = {"event": "ready", "port": port}
        if not given:
            doc["token"] = token
        line = json.dumps(doc, separators=(",", ":")) + "\n"
        os.write(ready_fd, line.encode())
        os.close(ready_fd)

    try:
        asyncio.run(run_server(args.host, args.port, token=token, max_message_bytes=args.max_message,
                               on_ready=ready, exit_on_stdin_eof=args.exit_on_stdin_eof))
    except OSError as exc:
        print(f"robwot_sim: cannot serve on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
