/** Loads `workspace.stl` + `workspace.csv` (+ `reachability.csv` when present) from a twin folder (Node only). */
import { existsSync } from "node:fs";
import { readFile } from "node:fs/promises";
import { join } from "node:path";
import { WorkspaceFileError } from "../errors.js";
import { reachabilityVoxel } from "./load-url.js";
import { ReachabilityMap } from "./reachability.js";
import { Workspace } from "./workspace.js";

async function read(file: string): Promise<Buffer> {
  try {
    return await readFile(file);
  } catch (cause) {
    const code = (cause as NodeJS.ErrnoException).code;
    throw new WorkspaceFileError(`cannot read ${file}${code === "ENOENT" ? ": no such file" : `: ${(cause as Error).message}`}`, { file, errno: code ?? null }, { cause });
  }
}

/** The reachability map of a twin folder; undefined for folders generated before it existed. */
async function loadReachability(dir: string): Promise<ReachabilityMap | undefined> {
  const file = join(dir, "reachability.csv");
  if (!existsSync(file)) return undefined;
  const summaryFile = join(dir, "workspace.json");
  const voxel = reachabilityVoxel((await read(summaryFile)).toString("utf8"), summaryFile);
  return ReachabilityMap.fromCsv((await read(file)).toString("utf8"), voxel, { file });
}

export async function loadWorkspace(dir: string): Promise<Workspace> {
  const stlFile = join(dir, "workspace.stl");
  const csvFile = join(dir, "workspace.csv");
  const [stl, csv, reach] = await Promise.all([read(stlFile), read(csvFile), loadReachability(dir)]);
  return Workspace.fromData(stl, csv.toString("utf8"), { stl: stlFile, csv: csvFile }, reach);
}
