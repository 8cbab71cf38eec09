/**
 * A stop that overtakes its relayed move: the move is on its way to the physical robot when `stop` comes,
 * and the physical robot gets the stop first (it answers `stopped: false`: nothing to stop yet). The
 * relay repeats the stop while its command is in flight, so the move is stopped once it arrives instead
 * of running. Between the twin and the physical robot (a second twin, `realtime: 1`, joints 20 times
 * slower than its model) runs an HTTP relay that holds a relayed move back until a stop has passed it; real
 * servients and backends.
 */
import { once } from "node:events";
import { createServer, request, type Server } from "node:http";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, slowPhysicalTwin, waitState } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";

/** Forwards every request to `target`; a POST to a move action is held (`onHeld` is told) until a stop has
 *  been answered by the target after it: the stop overtakes the move, however fast the machine is. TDs are
 *  rewritten so that their forms point at the relay. */
async function holdingRelay(target: string, onHeld: () => void): Promise<{ url: string; server: Server }> {
  const t = new URL(target);
  let self = "";
  let heldMoves: (() => void)[] = [];
  const server = createServer((req, res) => {
    const chunks: Buffer[] = [];
    req.on("data", (c: Buffer) => chunks.push(c));
    req.on("end", () => {
      const forward = (answered: () => void = () => undefined): void => {
        const up = request({ host: t.hostname, port: t.port, method: req.method, path: req.url, headers: { ...req.headers, host: t.host } }, (answer) => {
          const body: Buffer[] = [];
          answer.on("data", (c: Buffer) => body.push(c));
          answer.on("end", () => {
            const text = Buffer.concat(body).toString("utf8").replaceAll(t.origin, self);
            const headers = { ...answer.headers };
            delete headers["content-length"];
            res.writeHead(answer.statusCode ?? 502, headers);
            res.end(text);
            answered();
          });
        });
        up.on("error", () => res.destroy());
        up.end(Buffer.concat(chunks));
      };
      if (req.method === "POST" && /\/actions\/moveTo/.test(req.url ?? "")) {
        heldMoves.push(forward);
        onHeld();
      } else if (req.method === "POST" && /\/actions\/stop/.test(req.url ?? "")) {
        forward(() => {
          const release = heldMoves;
          heldMoves = [];
          for (const go of release) go();
        });
      } else forward();
    });
  });
  server.listen(0, "127.0.0.1");
  await once(server, "listening");
  self = `http://127.0.0.1:${(server.address() as { port: number }).port}`;
  return { url: self, server };
}

let physical: RunningServient;
let twin: RunningServient;
let relayServer: Server;
let pBase: string;
let vBase: string;
let held: () => void = () => undefined;

beforeAll(async () => {
  physical = await startServient({ twins: [await slowPhysicalTwin()], port: 0, realtime: 1 });
  pBase = `${physical.url}/${physical.things[0]!.slug}`;
  const relay = await holdingRelay(physical.url, () => held());
  relayServer = relay.server;
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: `${relay.url}/${physical.things[0]!.slug}` });
  vBase = `${twin.url}/${twin.things[0]!.slug}`;
});

afterAll(async () => {
  await twin?.stop();
  relayServer?.closeAllConnections();
  relayServer?.close();
  await physical?.stop();
});

it("a stop that reaches the physical robot before its relayed move still stops that move", async () => {
  const heldNow = new Promise<void>((resolve) => (held = resolve));
  const move = invoke(vBase, "moveToJointPosition", { joints: kukaPose([1.5, 0.3, 0, -0.8, 0, 0.4, 0]), speed: 0.05 });
  await heldNow;
  const stop = await invoke(vBase, "stop", "");
  expect(stop.status).toBe(200);
  expect(stop.body.stopped).toBe(true);
  expect(stop.body.physical.ok).toBe(true);
  // the first stop found nothing there; one sent after the move arrived stopped it
  expect(stop.body.physical.attempts).toBeGreaterThan(1);
  // the move answers stopped, whichever of the physical robot's two answers came first
  const r = await move;
  expect(r.body.status).toBe("stopped");
  if (r.body.relay.result) expect(r.body.relay.result.status).toBe("stopped");
  // the physical robot's move ended by the stop (a move that ran on would take a minute and end "idle")
  await waitState(pBase, "stopped");
  expect(Math.abs((await http(`${pBase}/properties/getJointPosition`)).body[J1])).toBeLessThan(0.05);
});
