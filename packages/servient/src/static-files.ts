/**
 * Static files: a twin folder's linked files (robot.urdf, meshes/, workspace.*, scene.json) and the
 * viewer bundle. Paths are confined to their root (no `..`, no symlink escape), content types follow
 * the TD's link types.
 */
import { createReadStream, existsSync, realpathSync, statSync } from "node:fs";
import type { IncomingMessage, ServerResponse } from "node:http";
import { extname, join, resolve, sep } from "node:path";
import { THING_MODEL_TYPE, TWIN_FILES, TWIN_FOLDERS } from "@robwot/core";
import { sendProblem, servientError } from "./errors.js";

const TYPES: Record<string, string> = {
  ".urdf": "application/urdf+xml",
  ".srdf": "application/xml",
  ".csv": "text/csv",
  ".stl": "model/stl",
  ".json": "application/json",
  ".dae": "model/vnd.collada+xml",
  ".obj": "model/obj",
  ".mtl": "model/mtl",
  ".png": "image/png",
  ".jpg": "image/jpeg",
  ".jpeg": "image/jpeg",
  ".html": "text/html; charset=utf-8",
  ".js": "text/javascript; charset=utf-8",
  ".mjs": "text/javascript; charset=utf-8",
  ".css": "text/css; charset=utf-8",
  ".map": "application/json",
  ".svg": "image/svg+xml",
  ".wasm": "application/wasm",
  ".txt": "text/plain; charset=utf-8",
};

export function contentType(path: string): string {
  if (path.endsWith(".tm.json")) return THING_MODEL_TYPE;
  return TYPES[extname(path).toLowerCase()] ?? "application/octet-stream";
}

/** Resolves `rel` (URL-decoded, `/`-separated) under `root`; null when it escapes or does not exist. */
export function confine(root: string, rel: string): string | null {
  if (rel.includes("\0") || rel.includes("\\")) return null;
  const parts = rel.split("/").filter((p) => p.length > 0);
  if (parts.some((p) => p === ".." || p === ".")) return null;
  const candidate = resolve(root, ...parts);
  if (!existsSync(candidate)) return null;
  let realRoot: string;
  let real: string;
  try {
    realRoot = realpathSync(root);
    real = realpathSync(candidate);
  } catch {
    return null;
  }
  if (real !== realRoot && !real.startsWith(realRoot + sep)) return null;
  return statSync(real).isFile() ? real : null;
}

/** The twin folder's fixed files served as they are (the URDF is served under the name twin.json gives). */
const SERVED_TWIN_FILES: ReadonlySet<string> = new Set([
  TWIN_FILES.pointCloud,
  TWIN_FILES.surface,
  TWIN_FILES.summary,
  TWIN_FILES.reachability,
  TWIN_FILES.scene,
  TWIN_FILES.srdf,
  TWIN_FILES.manifest,
  TWIN_FILES.thingModel,
]);

/** Twin-folder files served at `/<slug>/<rel>` (Contract 4; twin.json gives the viewer the base pose). */
export function isTwinFile(rel: string, urdfName: string): boolean {
  return rel === urdfName || SERVED_TWIN_FILES.has(rel) || rel.startsWith(`${TWIN_FOLDERS.meshes}/`);
}

export function sendFile(req: IncomingMessage, res: ServerResponse, path: string): void {
  const size = statSync(path).size;
  res.writeHead(200, { "Content-Type": contentType(path), "Content-Length": size });
  if (req.method === "HEAD") {
    res.end();
    return;
  }
  const stream = createReadStream(path);
  stream.on("error", () => res.destroy());
  stream.pipe(res);
}

export function sendJson(res: ServerResponse, status: number, body: unknown, type = "application/json"): void {
  const text = JSON.stringify(body);
  res.writeHead(status, { "Content-Type": type, "Content-Length": Buffer.byteLength(text) });
  res.end(text);
}

export function notFound(res: ServerResponse, what: string): void {
  sendProblem(res, servientError("E_NOT_FOUND", `${what} not found`, { path: what }));
}

export const defaultViewerDir = (here: string): string => join(here, "..", "..", "viewer", "dist");
