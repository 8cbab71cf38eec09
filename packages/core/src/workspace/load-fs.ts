/**
 * Loads `workspace.stl` + `workspace.csv` (+ `reachability.csv` when present) from a twin folder (Node
 * only). Each file must resolve inside the folder after symlinks (`folder-jail.ts`): one that leads
 * elsewhere is refused before it is read, so no parse error can quote another file's bytes.
 */
import { readFile } from "node:fs/promises";
import { join } from "node:path";
import { WorkspaceFileError } from "../errors.js";
import { jailFile, realFolder } from "../folder-jail.js";
import { TWIN_FILES } from "../twin-layout.js";
import { reachabilityVoxel } from "./load-url.js";
import { ReachabilityMap } from "./reachability.js";
import { Workspace } from "./workspace.js";

/** The real path of `name` in `dir`; null when optional and absent; refused when it leads out. */
function confined(dir: string, name: string, required: boolean): string | null {
  const root = realFolder(dir);
  const v = jailFile([root], root, name);
  if (v.ok) return v.real;
  const file = join(dir, name);
  if (v.why === "missing" && !required) return null;
  const why = { outside: "resolves outside its folder (a symlink to another file?): refused unread", missing: "no such file", "not-a-file": "is not a regular file", "not-a-path": "is not a file path" }[v.why];
  throw new WorkspaceFileError(`cannot read ${file}: ${why}`, { file, reason: v.why });
}

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
  const real = confined(dir, TWIN_FILES.reachability, false);
  if (real === null) return undefined;
  const file = join(dir, TWIN_FILES.reachability);
  const summaryFile = join(dir, TWIN_FILES.summary);
  const voxel = reachabilityVoxel((await read(confined(dir, TWIN_FILES.summary, true)!)).toString("utf8"), summaryFile);
  return ReachabilityMap.fromCsv((await read(real)).toString("utf8"), voxel, { file });
}

export async function loadWorkspace(dir: string): Promise<Workspace> {
  const stlFile = join(dir, TWIN_FILES.surface);
  const csvFile = join(dir, TWIN_FILES.pointCloud);
  const [stl, csv, reach] = await Promise.all([read(confined(dir, TWIN_FILES.surface, true)!), read(confined(dir, TWIN_FILES.pointCloud, true)!), loadReachability(dir)]);
  return Workspace.fromData(stl, csv.toString("utf8"), { stl: stlFile, csv: csvFile }, reach);
}
