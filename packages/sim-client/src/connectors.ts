/**
 * Connectors from the supervisor to a backend: launch our own `robwot_sim` process (restarted by the
 * supervisor when it dies), or connect to an external `ws://` URL (reconnected when it drops).
 */
import { launchBackend } from "./launcher.js";
import { RpcConnection } from "./rpc-connection.js";
import type { SimConnector, SimSession } from "./supervisor.js";

function session(
  conn: RpcConnection,
  extra: { pid?: number | undefined; closed?: Promise<unknown>; close?: () => Promise<void>; kill?: () => void },
): SimSession {
  return {
    // long calls (SimClient gives them no request deadline) are bounded by the supervisor's heartbeat
    call: (method, params, options) => conn.call(method, params, options),
    onNotification: (method, listener) => conn.onNotification(method, listener),
    closed: Promise.race([conn.closed, extra.closed ?? new Promise<never>(() => undefined)]).then(() => undefined),
    pid: extra.pid,
    close: extra.close ?? (() => conn.close()),
    kill: extra.kill ?? (() => conn.terminate()),
  };
}

/** Connections made here keep the contract's timeouts (`TRANSPORT`): a short method's request deadline; long
 *  methods carry none (the heartbeat bounds them). */
export function launchConnector(options: { python?: string | undefined } = {}): SimConnector {
  return async () => {
    const b = await launchBackend(options.python ? { python: options.python } : {});
    const conn = b.client.connection;
    return session(conn, {
      pid: b.pid,
      closed: b.exited,
      close: () => b.stop(),
      kill: () => {
        b.process.kill("SIGKILL"); // works on a stopped (SIGSTOP) process too
        conn.terminate();
      },
    });
  };
}

export function urlConnector(url: string): SimConnector {
  return async () => session(await RpcConnection.open(url), {});
}
