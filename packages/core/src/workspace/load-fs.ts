/** Loads `workspace.stl` + `workspace.csv` from a twin folder (Node only). */
import { readFile } from "node:fs/promises";
import { join } from "node:path";
import { WorkspaceFileError } from "../errors.js";
import { Workspace } from "./workspace.js";

async function read(file: string): Promise<Buffer> {
  try {
    return await readFile(file);
  } catch (cause) {
    const code = (cause as NodeJS.ErrnoException).code;
    throw new WorkspaceFileError(`cannot read ${file}${code === "ENOENT" ? ": no such file" : `: ${(cause as Error).message}`}`, { file, errno: code ?? null }, { cause });
  }
}

export async function loadWorkspace(dir: string): Promise<Workspace> {
  const stlFile = join(dir, "workspace.stl");
  const csvFile = join(dir, "workspace.csv");
  const [stl, csv] = await Promise.all([read(stlFile), read(csvFile)]);
  return Workspace.fromData(stl, csv.toString("utf8"), { stl: stlFile, csv: csvFile });
}
