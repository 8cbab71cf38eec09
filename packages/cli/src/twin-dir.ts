/**
 * Atomic output folder. Everything is written into a temporary folder next to the destination (same
 * file system, so `rename` is atomic); `commit()` swaps it in, `discard()` removes it. An existing output
 * is replaced only after the new one is complete: rename old away, rename new in, delete old.
 */
import { randomBytes } from "node:crypto";
import { chmodSync, existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, realpathSync, renameSync, rmdirSync, rmSync, statSync } from "node:fs";
import { homedir } from "node:os";
import { basename, dirname, join, parse, relative, resolve } from "node:path";
import { TWIN_FILES } from "@robwot/core/twin-layout";
import { CliError } from "./errors.js";

/** A file every complete twin folder contains; an existing folder without it is not ours to replace. */
export const TWIN_MARKER = TWIN_FILES.manifest;

const contains = (dir: string, path: string): boolean => {
  const rel = relative(dir, path);
  return rel === "" || (!rel.startsWith("..") && !parse(rel).root);
};

/** The path with every symbolic link resolved, also when its last parts do not exist yet. */
function realPath(path: string): string {
  const abs = resolve(path);
  try {
    return realpathSync.native(abs);
  } catch {
    // not there (yet): resolve the folder above and keep the name
    const parent = dirname(abs);
    return parent === abs ? abs : join(realPath(parent), basename(abs));
  }
}

/**
 * Refuses, before any work, outputs whose replacement would destroy what is not a twin: the file system
 * root, the home folder, the working folder or one of its ancestors, a repository root (it holds .git),
 * and any folder holding an input (URDF, scene, SRDF, package roots), whatever `--force` says, also when
 * reached through a symbolic link. Usage errors (exit 2).
 */
function checkNotAbsurd(out: string, inputs: readonly string[]): void {
  const real = realPath(out);
  const refuse = (why: string): never => {
    const via = real === out ? "" : ` (${real})`;
    throw new CliError(`refusing --out ${out}${via}: ${why}; choose a folder of its own, e.g. --out twins/<name>`, "E_USAGE");
  };
  if (real === parse(real).root) refuse("it is the file system root");
  if (real === realPath(homedir())) refuse("it is your home folder");
  if (contains(real, realPath(process.cwd()))) refuse("it holds the working folder");
  if (existsSync(join(real, ".git"))) refuse("it is the root of a repository (it holds .git)");
  for (const input of inputs) if (contains(real, realPath(input))) refuse(`it holds the input ${resolve(input)}`);
}

export class StagedDir {
  readonly out: string;
  readonly tmp: string;
  private done = false;
  private committed = false;
  /** The outermost folder this run had to create for the output's parent (removed again on failure). */
  private readonly createdRoot: string | undefined;

  private constructor(out: string, tmp: string, createdRoot: string | undefined) {
    this.out = out;
    this.tmp = tmp;
    this.createdRoot = createdRoot;
  }

  /**
   * Checks that `out` can be (re)placed and creates the temporary folder. Throws a `CliError`
   * (`E_OUTPUT`) naming the path when the destination is not writable or not replaceable.
   */
  static create(outArg: string, opts: { force?: boolean; inputs?: readonly string[] } = {}): StagedDir {
    const out = resolve(outArg);
    checkNotAbsurd(out, opts.inputs ?? []);
    if (existsSync(out)) {
      const st = statSync(out);
      if (!st.isDirectory()) throw new CliError(`output ${out} exists and is not a directory`, "E_OUTPUT");
      const entries = readdirSync(out);
      if (entries.length > 0 && !entries.includes(TWIN_MARKER) && !opts.force) {
        throw new CliError(
          `output ${out} exists and is not a twin folder (no ${TWIN_MARKER}); refusing to replace it (use --force, or another --out)`,
          "E_OUTPUT",
          2,
        );
      }
    }
    const parent = dirname(out);
    let createdRoot: string | undefined;
    try {
      createdRoot = mkdirSync(parent, { recursive: true });
    } catch (err) {
      throw new CliError(`cannot create output folder ${parent}: ${(err as Error).message}`, "E_OUTPUT");
    }
    let tmp: string;
    try {
      tmp = mkdtempSync(join(parent, `.${basename(out)}.tmp-`));
    } catch (err) {
      throw new CliError(`output folder ${parent} is not writable: ${(err as Error).message}`, "E_OUTPUT");
    }
    return new StagedDir(out, tmp, createdRoot);
  }

  /**
   * Refuses (`E_OUTPUT`, exit 2) to replace a twin of another robot (its twin.json names another robot)
   * unless `force`: regenerating a twin is routine, overwriting someone else's by a typo in `--out` is not.
   */
  refuseOtherRobot(robot: string, force: boolean): void {
    if (force || !existsSync(join(this.out, TWIN_MARKER))) return;
    let existing: unknown;
    try {
      existing = (JSON.parse(readFileSync(join(this.out, TWIN_MARKER), "utf8")) as { robot?: { name?: unknown } }).robot?.name;
    } catch {
      return; // not readable as a twin.json: the folder is replaced as any twin folder
    }
    if (typeof existing === "string" && existing !== robot) {
      throw new CliError(
        `output ${this.out} holds the twin of robot "${existing}", not "${robot}": refusing to replace it (use --force, or another --out)`,
        "E_OUTPUT",
        2,
      );
    }
  }

  /** Moves the finished folder into place, replacing a previous output only now. */
  commit(): void {
    if (this.done) throw new Error("StagedDir already committed or discarded");
    // mkdtemp made it private (0700); a twin folder is meant to be read and served
    chmodSync(this.tmp, 0o755);
    let old: string | null = null;
    if (existsSync(this.out)) {
      old = join(dirname(this.out), `.${basename(this.out)}.old-${randomBytes(4).toString("hex")}`);
      renameSync(this.out, old);
    }
    try {
      renameSync(this.tmp, this.out);
    } catch (err) {
      if (old !== null) renameSync(old, this.out);
      throw new CliError(`cannot move ${this.tmp} to ${this.out}: ${(err as Error).message}`, "E_OUTPUT");
    }
    this.done = true;
    this.committed = true;
    if (old !== null) rmSync(old, { recursive: true, force: true });
  }

  /** Removes the temporary folder (a committed folder is left alone). Safe to call again: a backend
   *  still writing when it was first called may have created files since. */
  discard(): void {
    if (this.committed) return;
    this.done = true;
    rmSync(this.tmp, { recursive: true, force: true });
    // a failed run leaves nothing behind: also the (still empty) parent folders it created
    if (this.createdRoot === undefined) return;
    for (let dir = dirname(this.tmp); ; dir = dirname(dir)) {
      try {
        rmdirSync(dir);
      } catch {
        return; // not empty (someone else's files): keep it
      }
      if (dir === this.createdRoot) return;
    }
  }
}
