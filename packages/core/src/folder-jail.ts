/**
 * A folder as a jail (Node only): a path named inside a folder's files (a twin folder's twin.json,
 * scene.json, ...) is used only when it resolves inside the folder, or inside one of a few other roots
 * the operator named, after every symlink. A file that leads elsewhere is refused before it is read, so
 * no error about its content can quote another file's bytes.
 */
import { existsSync, realpathSync, statSync } from "node:fs";
import { isAbsolute, resolve, sep } from "node:path";

export type JailVerdict =
  | { ok: true; real: string }
  /** outside: lexically or after symlinks; missing: no such file; not-a-file: a folder, FIFO, device... */
  | { ok: false; why: "outside" | "missing" | "not-a-file" | "not-a-path" };

const within = (root: string, p: string): boolean => p === root || p.startsWith(root.endsWith(sep) ? root : root + sep);

/** The real path of a folder (symlinks resolved); the folder itself when it does not exist. */
export function realFolder(dir: string): string {
  try {
    return realpathSync(resolve(dir));
  } catch {
    return resolve(dir);
  }
}

/**
 * Resolves `entry` (relative to `base`, or absolute) and checks it against `roots` (real paths, see
 * `realFolder`): first the path as written (a `..` out is refused before the file system is asked),
 * then its real path. Only a regular file passes.
 */
export function jailFile(roots: readonly string[], base: string, entry: unknown): JailVerdict {
  if (typeof entry !== "string" || entry.length === 0 || entry.length > 4096 || entry.includes("\0")) return { ok: false, why: "not-a-path" };
  const candidate = isAbsolute(entry) ? resolve(entry) : resolve(base, entry);
  if (!roots.some((r) => within(r, candidate))) return { ok: false, why: "outside" };
  if (!existsSync(candidate)) return { ok: false, why: "missing" };
  let real: string;
  try {
    real = realpathSync(candidate);
  } catch {
    return { ok: false, why: "missing" };
  }
  if (!roots.some((r) => within(r, real))) return { ok: false, why: "outside" };
  return statSync(real).isFile() ? { ok: true, real } : { ok: false, why: "not-a-file" };
}
