import { ViewerError } from "./errors.js";

/** Fetch and parse JSON; HTTP errors become ViewerError carrying the servient's `{code, message, details}`. */
export async function fetchJson(url: string, init?: RequestInit): Promise<unknown> {
  const res = await fetchOk(url, init);
  const text = await res.text();
  if (text.length === 0) return undefined;
  try {
    return JSON.parse(text) as unknown;
  } catch {
    throw new ViewerError("E_BAD_JSON", `${url} did not answer JSON`, { body: text.slice(0, 200) });
  }
}

export async function fetchText(url: string): Promise<string> {
  return (await fetchOk(url)).text();
}

export async function fetchBuffer(url: string): Promise<ArrayBuffer> {
  return (await fetchOk(url)).arrayBuffer();
}

async function fetchOk(url: string, init?: RequestInit): Promise<Response> {
  let res: Response;
  try {
    res = await fetch(url, init);
  } catch (err) {
    throw new ViewerError("E_NETWORK", `cannot reach ${url}: ${String(err)}`);
  }
  if (res.ok) return res;
  const body = await res.text();
  let parsed: unknown = null;
  try {
    parsed = JSON.parse(body);
  } catch {
    // not JSON: report the text below
  }
  if (isRecord(parsed) && typeof parsed["message"] === "string") {
    const code = typeof parsed["code"] === "string" ? parsed["code"] : `HTTP_${res.status}`;
    const details = isRecord(parsed["details"]) ? parsed["details"] : {};
    throw new ViewerError(code, parsed["message"], { status: res.status, url, ...details });
  }
  throw new ViewerError(`HTTP_${res.status}`, `${init?.method ?? "GET"} ${url} failed: ${res.status} ${res.statusText}`, {
    body: body.slice(0, 300),
  });
}

export function isRecord(v: unknown): v is Record<string, unknown> {
  return typeof v === "object" && v !== null && !Array.isArray(v);
}
