/**
 * Connectors from the supervisor to a backend: launch our own `robwot_sim` process (restarted by the
 * supervisor when it dies), or connect to an external `ws://` URL (reconnected when it drops).
 */
import { launchBackend, type ExitInfo } from "./launcher.js";
import type { SpawnedBackend } from "./spawn.js";
import { RpcConnection } from "./rpc-connection.js";
import type { SimConnector, SimSession } from "./supervisor.js";

function session(
  conn: RpcConnection,
  extra: { pid?: number | undefined; closed?: Promise<unknown>; close?: () => Promise<void>; kill?: () => void; exited?: Promise<string> },
): SimSession {
  return {
    // long calls (SimClient gives them no request deadline) are bounded by the supervisor's heartbeat
    call: (method, params, options) => conn.call(method, params, options),
    onNotification: (method, listener) => conn.onNotification(method, listener),
    closed: Promise.race([conn.closed, extra.closed ?? new Promise<never>(() => undefined)]).then(() => undefined),
    pid: extra.pid,
    close: extra.close ?? (() => conn.close()),
    kill: extra.kill ?? (() => conn.terminate()),
    ...(extra.exited !== undefined ? { exited: extra.exited } : {}),
  };
}

/** How a process ended, with its last words: from a native crash's report (Python's faulthandler, which the
 *  backend enables) on, else the last lines it wrote to stderr. */
export function describeExit(info: ExitInfo, stderr: string): string {
  const how = info.signal !== null ? `was killed by ${info.signal}` : `exited with code ${String(info.code)}`;
  const lines = stderr.split("\n").filter((l) => l.trim() !== "");
  const fatal = lines.findIndex((l) => l.startsWith("Fatal Python error"));
  const words = (fatal >= 0 ? lines.slice(fatal, fatal + 24) : lines.slice(-5)).join("\n");
  return words === "" ? how : `${how}; its last words on stderr:\n${words}`;
}

/** Connections made here keep the contract's timeouts (`TRANSPORT`): a short method's request deadline; long
 *  methods carry none (the heartbeat bounds them). */
export function launchConnector(options: { python?: string | undefined; warmWorkers?: number | undefined; spawned?: SpawnedBackend | undefined } = {}): SimConnector {
  // a process started already (`spawnBackend`) is the first session's; a restart starts another
  let spawned = options.spawned;
  return async () => {
    const first = spawned;
    spawned = undefined;
    const b = await launchBackend({
      ...(options.python ? { python: options.python } : {}),
      ...(options.warmWorkers !== undefined ? { warmWorkers: options.warmWorkers } : {}),
      ...(first !== undefined ? { spawned: first } : {}),
    });
    const conn = b.client.connection;
    return session(conn, {
      pid: b.pid,
      closed: b.exited,
      exited: b.exited.then((info) => describeExit(info, b.stderr)),
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
