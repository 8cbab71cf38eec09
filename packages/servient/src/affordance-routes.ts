/**
 * The affordance routes the router answers itself, from one Thing's `Affordances` (property readers and
 * action handlers by name): `readproperty` (`GET <thing>/properties/<name>`), `readallproperties`
 * (`GET <thing>/properties`) and `invokeaction` (`POST <thing>/actions/<name>`, its body already read,
 * parsed and checked against the TD by the router: handlers get the value, parsed once). A handler's
 * failure is thrown to the router, which answers it as problem details with its own status.
 *
 * node-wot keeps what it does well: producing the Thing, and the long-poll `observeproperty` /
 * `subscribeevent` routes, fed by the same readers (`registerReaders`).
 */
import type { ServerResponse } from "node:http";
import { badInput } from "./errors.js";
import { sendJson } from "./static-files.js";

/** An action handler: the input (validated against the TD's schema), and for an asynchronous invocation
 *  (`Prefer: respond-async`, `action-status.ts`) a watch told once the move is accepted. */
export type ActionHandler = (input: unknown, watch?: (handle: never) => void) => Promise<unknown>;

/** A property value answered as bytes of its own media type instead of JSON (e.g. a point cloud file). */
export interface PropertyBytes {
  contentType: string;
  body: Buffer;
}

/** A property reader: the property's value (answered as JSON) or `PropertyBytes`, either possibly as a promise. */
export type PropertyReader = () => unknown;

/** One Thing's readable properties and actions, by name. */
export interface Affordances {
  properties: Map<string, PropertyReader>;
  actions: Map<string, ActionHandler>;
  /** writable properties (`writeproperty`, `PUT <thing>/properties/<name>`): the value's schema, the writer */
  writers?: Map<string, PropertyWriter>;
}

/** A writable property: its value checked against `schema` by the router, then written. */
export interface PropertyWriter {
  schema: object;
  write(value: unknown): Promise<void>;
}

/** `writeproperty`: 204 once written (the value read, parsed and checked by the router). */
export async function writeProperty(res: ServerResponse, writer: PropertyWriter, value: unknown): Promise<void> {
  await writer.write(value);
  res.writeHead(204);
  res.end();
}

/** The input of an action that takes an object (the schema says so; an absent body is refused here). */
export function objectInput<T>(v: unknown, action: string): T {
  if (v === null || typeof v !== "object" || Array.isArray(v)) throw badInput("expected a JSON object as input", { action, got: v ?? null });
  return v as T;
}

const isBytes = (v: unknown): v is PropertyBytes =>
  typeof v === "object" && v !== null && Buffer.isBuffer((v as Partial<PropertyBytes>).body) && typeof (v as Partial<PropertyBytes>).contentType === "string";

/**
 * `readproperty` of `name` (JSON, or the reader's bytes with their media type), or `readallproperties`
 * without one: every readable property's JSON value (a property read as bytes has none: it is left out).
 */
export async function readProperty(res: ServerResponse, a: Affordances, name?: string): Promise<void> {
  if (name !== undefined) {
    const value: unknown = await a.properties.get(name)?.();
    if (!isBytes(value)) return sendJson(res, 200, value);
    res.writeHead(200, { "Content-Type": value.contentType, "Content-Length": value.body.length });
    return void res.end(value.body);
  }
  const values = await Promise.all([...a.properties].map(async ([n, read]): Promise<[string, unknown]> => [n, await read()]));
  sendJson(res, 200, Object.fromEntries(values.filter(([, v]) => !isBytes(v))));
}

/** `invokeaction`: 200 with the handler's output as JSON, 204 when it has none. */
export async function invokeAction(res: ServerResponse, handler: ActionHandler, input: unknown): Promise<void> {
  const output = await handler(input);
  if (output === undefined) {
    res.writeHead(204);
    return void res.end();
  }
  sendJson(res, 200, output);
}

/** node-wot's read handlers from the readers (its long-poll observers re-read a property on change). */
export function registerReaders(thing: WoT.ExposedThing, properties: Map<string, PropertyReader>): void {
  for (const [name, read] of properties) thing.setPropertyReadHandler(name, async () => read() as WoT.InteractionInput);
}
