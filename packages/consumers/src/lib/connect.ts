/**
 * Connecting to a RobWoT twin: resolve the TD URL, fetch the TD (with optional credentials), consume
 * it with a node-wot Servient + HttpClientFactory, and clean up.
 *
 * TD URL: first positional argument, else env `ROBWOT_TD`, else the demo's
 * `http://127.0.0.1:8080/<DEMO_SLUG>`. Credentials: env `ROBWOT_AUTH` = `basic:USER:PASS` or
 * `bearer:TOKEN` (the same syntax as `robwot serve --auth`).
 */
import type * as WoTTypes from "wot-typescript-definitions";
import { loadNodeWot, silenceAjvFormatWarnings } from "./node-wot.js";
import type { SchemaLike, ThingDescriptionLike } from "@robwot/core";
import { RobwotError } from "@robwot/core";

/** The Thing slug `npm start` / `robwot demo` serves (the bundled kuka_iiwa, TD title "lbr_iiwa"). */
export const DEMO_SLUG = "lbr_iiwa";
export const DEFAULT_TD_URL = `http://127.0.0.1:8080/${DEMO_SLUG}`;

export function defaultTdUrl(envName = "ROBWOT_TD", fallback = DEFAULT_TD_URL): string {
  const fromEnv = process.env[envName];
  return fromEnv !== undefined && fromEnv !== "" ? fromEnv : fallback;
}

export type Auth = { scheme: "basic"; username: string; password: string } | { scheme: "bearer"; token: string };

export function authFromEnv(): Auth | undefined {
  const raw = process.env["ROBWOT_AUTH"];
  if (raw === undefined || raw === "") return undefined;
  const [scheme, ...rest] = raw.split(":");
  if (scheme === "basic" && rest.length >= 2) {
    return { scheme, username: rest[0] as string, password: rest.slice(1).join(":") };
  }
  if (scheme === "bearer" && rest.length >= 1) return { scheme, token: rest.join(":") };
  throw new Error(`ROBWOT_AUTH must be basic:USER:PASS or bearer:TOKEN, got scheme "${scheme ?? ""}"`);
}

export function authHeaders(auth: Auth | undefined): Record<string, string> {
  if (auth === undefined) return {};
  if (auth.scheme === "bearer") return { authorization: `Bearer ${auth.token}` };
  const basic = Buffer.from(`${auth.username}:${auth.password}`).toString("base64");
  return { authorization: `Basic ${basic}` };
}

/** GET a URL, failing with the status and the start of the body (never a silent empty result). */
export async function fetchOk(url: string, auth: Auth | undefined): Promise<Response> {
  let res: Response;
  try {
    res = await fetch(url, { headers: authHeaders(auth) });
  } catch (err) {
    throw new Error(`cannot reach ${url}: ${(err as Error).cause instanceof Error ? ((err as Error).cause as Error).message : String(err)}. Is the twin served (npm start / robwot serve)?`);
  }
  if (!res.ok) {
    const body = (await res.text()).slice(0, 300);
    const hint = res.status === 401 ? (auth === undefined ? " (set ROBWOT_AUTH=basic:USER:PASS or bearer:TOKEN)" : " (check ROBWOT_AUTH)") : "";
    throw new Error(`GET ${url} answered ${res.status} ${res.statusText}${body ? `: ${body}` : ""}${hint}`);
  }
  return res;
}

export interface Twin {
  url: string;
  td: ThingDescriptionLike;
  thing: WoTTypes.ConsumedThing;
  auth: Auth | undefined;
}

export interface Session {
  connect(url: string): Promise<Twin>;
  close(): Promise<void>;
}

/** One node-wot client Servient; consume any number of twins with it. */
export async function openSession(): Promise<Session> {
  silenceAjvFormatWarnings();
  const { Servient, HttpClientFactory } = loadNodeWot();
  const servient = new Servient();
  servient.addClientFactory(new HttpClientFactory(null));
  const wot = await servient.start();
  const auth = authFromEnv();
  return {
    async connect(url: string): Promise<Twin> {
      const td = (await (await fetchOk(url, auth)).json()) as ThingDescriptionLike;
      if (auth !== undefined && typeof td.id === "string") {
        servient.addCredentials({
          [td.id]: auth.scheme === "basic" ? { username: auth.username, password: auth.password } : { token: auth.token },
        });
      }
      const thing = await wot.consume(td as WoTTypes.ThingDescription);
      return { url, td, thing, auth };
    },
    async close(): Promise<void> {
      await servient.shutdown();
    },
  };
}

const warned = new Set<string>();

/** Numeric min/max violations of `value` against `schema` (object properties, recursively). */
export function schemaViolations(value: unknown, schema: SchemaLike | undefined, path = ""): string[] {
  if (schema === undefined) return [];
  if (typeof value === "number") {
    const out: string[] = [];
    if (typeof schema.minimum === "number" && value < schema.minimum) out.push(`${path || "value"}=${value} < minimum ${schema.minimum}`);
    if (typeof schema.maximum === "number" && value > schema.maximum) out.push(`${path || "value"}=${value} > maximum ${schema.maximum}`);
    return out;
  }
  if (value !== null && typeof value === "object" && schema.properties !== undefined) {
    return Object.entries(schema.properties).flatMap(([k, sub]) =>
      schemaViolations((value as Record<string, unknown>)[k], sub, path ? `${path}.${k}` : k),
    );
  }
  return [];
}

/**
 * Read a property and return its decoded value. node-wot's `value()` rejects a value outside the TD's
 * schema; then the property is read again undecoded and a warning names the violation (a twin whose
 * TD declares too narrow bounds is reported, not fatal to the scenario).
 */
export async function read<T>(twin: Twin, name: string): Promise<T> {
  const out = await twin.thing.readProperty(name);
  try {
    return (await out.value()) as T;
  } catch (err) {
    if (!/Invalid value according to DataSchema/i.test((err as Error).message)) throw err;
    const raw = await twin.thing.readProperty(name);
    const value = JSON.parse(new TextDecoder().decode(await raw.arrayBuffer())) as T;
    if (!warned.has(name)) {
      warned.add(name);
      const why = schemaViolations(value, twin.td.properties?.[name]).join(", ") || (err as Error).message;
      console.error(`warning: ${name} of ${twin.url} does not match its TD schema (${why}); using the value anyway`);
    }
    return value;
  }
}

/** Invoke an action and return its decoded output; errors name the action and the twin. `options`:
 *  node-wot's, e.g. `formIndex` to choose one of the action's forms. */
export async function invoke<T>(twin: Twin, name: string, input?: unknown, options?: WoTTypes.InteractionOptions): Promise<T> {
  let out: WoTTypes.InteractionOutput | undefined;
  try {
    out = await twin.thing.invokeAction(name, input as WoTTypes.InteractionInput, options);
  } catch (err) {
    throw new ActionError(name, twin.url, err);
  }
  return (out === undefined ? undefined : await out.value()) as T;
}

export class ActionError extends RobwotError {
  override name = "ActionError";
  constructor(
    readonly action: string,
    readonly url: string,
    cause: unknown,
  ) {
    super("E_ACTION", `${action} on ${url} failed: ${cause instanceof Error ? cause.message : String(cause)}`, { action, url }, { cause });
  }
}
