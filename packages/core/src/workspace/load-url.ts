/** Loads a twin's workspace files over HTTP (consumers, browser). Pure: uses the given `fetch`. */
import { WorkspaceFileError } from "../errors.js";
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

/** Fetches workspace.stl and workspace.csv (e.g. the TD's `workspace` and `workspace-pointcloud` links). */
export async function loadWorkspaceFromUrls(stlUrl: string, csvUrl: string, fetchFn: FetchLike = globalThis.fetch): Promise<Workspace> {
  const [stlRes, csvRes] = await Promise.all([get(stlUrl, fetchFn), get(csvUrl, fetchFn)]);
  const [stl, csv] = await Promise.all([stlRes.arrayBuffer(), csvRes.text()]);
  return Workspace.fromData(stl, csv, { stl: stlUrl, csv: csvUrl });
}
