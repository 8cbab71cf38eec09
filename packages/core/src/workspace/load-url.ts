/** Loads a twin's workspace files over HTTP (consumers, browser). Pure: uses the given `fetch`. */
import { WorkspaceFileError } from "../errors.js";
import { jsonErrorAt } from "../snippet.js";
import { TWIN_FILES } from "../twin-layout.js";
import { ReachabilityMap } from "./reachability.js";
import { Workspace } from "./workspace.js";

export type FetchLike = (url: string) => Promise<{ ok: boolean; status: number; statusText: string; arrayBuffer(): Promise<ArrayBuffer>; text(): Promise<string> }>;

async function get(url: string, fetchFn: FetchLike): Promise<Awaited<ReturnType<FetchLike>>> {
  let res: Awaited<ReturnType<FetchLike>>;
  try {
    res = await fetchFn(url);
  } catch (cause) {
    throw new WorkspaceFileError(`cannot fetch ${url}: ${(cause as Error).message ?? String(cause)}`, { url }, { cause });
  }
  if (!res.ok) throw new WorkspaceFileError(`GET ${url} answered ${res.status} ${res.statusText}`, { url, status: res.status });
  return res;
}

/** The voxel side (m) of reachability.csv, from the text of workspace.json (`reachability.voxel`). */
export function reachabilityVoxel(summaryText: string, file: string): number {
  let voxel: unknown;
  try {
    voxel = (JSON.parse(summaryText) as { reachability?: { voxel?: unknown } }).reachability?.voxel;
  } catch (cause) {
    throw new WorkspaceFileError(`${file} is not valid JSON${jsonErrorAt(cause, summaryText)}`, { file });
  }
  if (typeof voxel !== "number" || !(voxel > 0) || !Number.isFinite(voxel)) {
    throw new WorkspaceFileError(`${file} has no reachability.voxel (a positive number of metres), needed to read ${TWIN_FILES.reachability}`, { file });
  }
  return voxel;
}

/**
 * Fetches workspace.stl and workspace.csv (the TD's `workspace` and `workspace-pointcloud` links) and,
 * when given, reachability.csv with workspace.json (links `robwot:reachability`, `workspace-summary`).
 */
export async function loadWorkspaceFromUrls(
  stlUrl: string,
  csvUrl: string,
  fetchFn: FetchLike = globalThis.fetch,
  reach?: { csvUrl: string; summaryUrl: string },
): Promise<Workspace> {
  const [stlRes, csvRes] = await Promise.all([get(stlUrl, fetchFn), get(csvUrl, fetchFn)]);
  const [stl, csv] = await Promise.all([stlRes.arrayBuffer(), csvRes.text()]);
  let map: ReachabilityMap | undefined;
  if (reach) {
    const [mapText, summaryText] = await Promise.all([get(reach.csvUrl, fetchFn).then((r) => r.text()), get(reach.summaryUrl, fetchFn).then((r) => r.text())]);
    map = ReachabilityMap.fromCsv(mapText, reachabilityVoxel(summaryText, reach.summaryUrl), { file: reach.csvUrl });
  }
  return Workspace.fromData(stl, csv, { stl: stlUrl, csv: csvUrl }, map);
}
