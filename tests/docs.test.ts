/**
 * The docs test: every shell command block of the READMEs runs as written (issue 23, item 5).
 *
 * Every fenced block tagged sh / bash / shell / zsh / console of README.md, packages/*\/README.md,
 * sim-backend/*.md is extracted and run with bash from the repository root, in order, all blocks of one
 * file in one bash process (its own process group: `export`, `cd` and background servers carry over to
 * the next block as in a terminal), against real twins the blocks generate themselves. Asserted per block:
 * - every foreground command exits 0 (bash ERR trap: the failing README line is named);
 * - every `curl` answers the HTTP status its trailing comment states (`... # 401`), else a 2xx;
 * - blocks on SKIP do not run (each with its reason); every SKIP / PRELUDE / STREAM entry must match a
 *   block, so these lists cannot rot.
 * PRELUDE entries set up what a block's prose says it needs (e.g. "against the demo": `npm start`) and
 * stop the servers of earlier blocks (as a reader would with Ctrl-C); they never change the block itself.
 * Twins the blocks write under twins/ are removed afterwards (a twins/ entry that existed before is kept;
 * a target that already exists fails the test rather than being overwritten); background servers are
 * stopped with SIGTERM, then the process group is killed. The ports the blocks use must be free: a busy
 * one fails the test naming it.
 */
import { spawn } from "node:child_process";
import { existsSync, mkdtempSync, readdirSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { createServer } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";

const REPO = join(import.meta.dirname, "..");

export interface Block {
  file: string;
  /** 1-based line of the block's first command line in the file */
  line: number;
  lang: string;
  text: string;
}

const SHELL_LANGS = new Set(["sh", "bash", "shell", "zsh", "console", "shell-session"]);

/** Every fenced shell block of a Markdown text (``` or ~~~ fences; `console` blocks: `$ ` lines only). */
export function extractBlocks(markdown: string, file: string): Block[] {
  const lines = markdown.split("\n");
  const blocks: Block[] = [];
  for (let i = 0; i < lines.length; i++) {
    const open = /^\s*(`{3,}|~{3,})\s*([\w-]*)/.exec(lines[i]!);
    if (!open) continue;
    const fence = open[1]!;
    const lang = open[2]!.toLowerCase();
    let j = i + 1;
    while (j < lines.length && !lines[j]!.trim().startsWith(fence)) j++;
    const body = lines.slice(i + 1, j);
    if (SHELL_LANGS.has(lang)) {
      const text =
        lang === "console" || lang === "shell-session"
          ? body.map((l) => (/^\s*\$ /.test(l) ? l.replace(/^\s*\$ /, "") : "")).join("\n")
          : body.join("\n");
      blocks.push({ file, line: i + 2, lang, text });
    }
    i = j;
  }
  return blocks;
}

/** A logical command: physical lines joined by trailing backslashes; `expect` = the status in its trailing comment. */
interface Command {
  first: number; // 0-based line within the block
  last: number;
  text: string;
  curl: boolean;
  expectStatus: number | null;
  /** a loop condition (`until curl ...`): its answers are not checked */
  loop: boolean;
}

export function commandsOf(block: Block): Command[] {
  const lines = block.text.split("\n");
  const out: Command[] = [];
  for (let i = 0; i < lines.length; i++) {
    const first = i;
    while (i < lines.length - 1 && /\\\s*$/.test(lines[i]!)) i++;
    const text = lines.slice(first, i + 1).join("\n");
    if (!text.trim() || /^\s*#/.test(text)) continue;
    const comment = /\s#\s*(.*)$/.exec(lines[i]!);
    const status = comment ? /^(\d{3})\b/.exec(comment[1]!) : null;
    out.push({
      first,
      last: i,
      text,
      curl: /(^|[\s;(&|`$])curl\s/.test(text),
      expectStatus: status ? Number(status[1]) : null,
      loop: /^\s*(until|while)\b/.test(text),
    });
  }
  return out;
}

interface Entry {
  file: string;
  /** a distinctive substring of the block */
  match: string;
  reason: string;
}
/** Blocks that cannot run in a test, each with why. */
const SKIP: Entry[] = [
  {
    file: "README.md",
    match: "npm install && npm start",
    reason: "the quick start is what CI's .ci/run does itself (npm install, npm test); `npm start` serves until Ctrl-C and `npm test` would run this test again",
  },
  {
    file: "packages/consumers/README.md",
    match: "--out twins/physical",
    reason: "its calibrate action writes calibration.json into twins/demo-kuka, which the README blocks after it serve through the demo; the scenario runs in tests/consumers.test.ts",
  },
  {
    file: "sim-backend/PROTOCOL.md",
    match: "python -m robwot_sim serve [--host",
    reason: "a usage synopsis ([optional] arguments), not a command; the backend is run by plain_client.py below",
  },
  {
    file: "sim-backend/PROTOCOL.md",
    match: "ROBWOT_BACKEND_TOKEN=... ",
    reason: "`...` stands for the token a backend started by hand prints; needs that backend on port 8765",
  },
];

interface Prelude extends Entry {
  script: string;
}
/** Set up what a block's prose says it needs; runs in the block's shell just before it. */
// a job is `npx` -> npm -> sh -> node (+ its Python backend): signal its whole tree, as Ctrl-C or `kill %1`
// in an interactive shell signals the job's process group (npm does not pass SIGTERM on)
const STOP_SERVERS = `for __j in $(jobs -p); do kill -TERM $(__docs_tree $__j) 2>/dev/null; done; wait 2>/dev/null`;
const waitFor = (url: string) =>
  `for __i in $(seq 240); do curl -s -o /dev/null ${url} && break; sleep 0.5; done; command curl -s -o /dev/null ${url}`;
const DEMO = `${STOP_SERVERS}; npx robwot demo --port 8080 >/dev/null & ${waitFor("http://127.0.0.1:8080/lbr_iiwa")}`;
const PRELUDES: Prelude[] = [
  { file: "README.md", match: "Prefer: respond-async", reason: "the async example drives the demo (`npm start`) on 8080", script: DEMO },
  { file: "README.md", match: 'new W("ws://127.0.0.1:8080/live")', reason: "the live example follows the demo (`npm start`)", script: DEMO },
  { file: "README.md", match: "--auth basic:u:p &", reason: "port 8080: stop the servers of the blocks above (Ctrl-C)", script: STOP_SERVERS },
  {
    file: "packages/consumers/README.md",
    match: "npm run consumer:read-and-move-joints",
    reason: "the consumers drive the demo twin: `npm start` in another terminal",
    script: DEMO,
  },
];

interface Stream extends Entry {
  seconds: number;
  /** what the output must hold by then */
  expect: RegExp[];
}
/** Blocks that run until Ctrl-C: interrupted (SIGINT to their process group) after `seconds`. */
const STREAM: Stream[] = [
  {
    file: "README.md",
    match: 'new W("ws://127.0.0.1:8080/live")',
    reason: "prints the live stream until Ctrl-C; the README says it prints a joints, a status and a scene message first",
    seconds: 6,
    expect: [/"type":"joints"/, /"type":"status"/, /"type":"scene"/],
  },
];

const entryFor = <T extends Entry>(list: T[], b: Block): T | undefined => list.find((e) => e.file === b.file && b.text.includes(e.match));

export interface BlockResult {
  block: Block;
  skipped?: string;
  output: string;
  failures: string[];
}

const MARK = "@@docs-test-block";

/** The bash script running `blocks` in order, and the lines of each block's body in it (1-based). */
function buildScript(blocks: Block[], log: string, dir: string): { script: string; ranges: { from: number; block: Block }[] } {
  const lines: string[] = [
    "exec 2>&1",
    `__docs_log=${JSON.stringify(log)}`,
    `trap 'echo "ERR $LINENO $?" >> "$__docs_log"' ERR`,
    `__docs_tree() { echo "$1"; local __c; for __c in $(pgrep -P "$1"); do __docs_tree "$__c"; done; }`,
    // records each curl's final HTTP status (headers dumped to a file; what curl prints is unchanged)
    `curl() { local __h; __h=$(mktemp); command curl -D "$__h" "$@"; local __rc=$?; local __st; __st=$(grep -a '^HTTP/' "$__h" | tail -n 1 | cut -d ' ' -f 2); rm -f "$__h"; echo "CURL \${BASH_LINENO[0]} \${__st:-none} $__rc" >> "$__docs_log"; return $__rc; }`,
  ];
  const ranges: { from: number; block: Block }[] = [];
  blocks.forEach((b, n) => {
    lines.push(`printf '\\n${MARK} ${n} start\\n'`);
    const prelude = entryFor(PRELUDES, b);
    // in this shell (not a subshell), so that the servers it starts are this shell's jobs
    if (prelude) lines.push("trap - ERR", `{ ${prelude.script}; } >/dev/null || echo "PRELUDE ${n} $?" >> "$__docs_log"`, `trap 'echo "ERR $LINENO $?" >> "$__docs_log"' ERR`);
    const stream = entryFor(STREAM, b);
    if (stream) {
      const f = join(dir, `block-${n}.sh`);
      writeFileSync(f, b.text + "\n");
      // GNU timeout signals the block's whole process group; 124 = it ran until interrupted
      ranges.push({ from: lines.length + 1, block: b });
      lines.push(`timeout -s INT ${stream.seconds} bash ${f} || { __s=$?; [ $__s = 124 ] || (exit $__s); }`);
    } else {
      ranges.push({ from: lines.length + 1, block: b });
      lines.push(...b.text.split("\n"));
    }
    lines.push(`printf '\\n${MARK} ${n} end\\n'`);
  });
  lines.push("trap - ERR", STOP_SERVERS);
  return { script: lines.join("\n") + "\n", ranges };
}

/** Runs the blocks of one file in one bash process group; kills the group when done or after `timeoutMs`. */
export async function runBlocks(blocks: Block[], timeoutMs: number): Promise<BlockResult[]> {
  const dir = mkdtempSync(join(tmpdir(), "robwot-docs-"));
  const log = join(dir, "log");
  writeFileSync(log, "");
  const { script, ranges } = buildScript(blocks, log, dir);
  const scriptFile = join(dir, "blocks.sh");
  writeFileSync(scriptFile, script);
  const env = { ...process.env };
  for (const k of ["ROBWOT_TD", "ROBWOT_AUTH", "ROBWOT_PHYSICAL_TD", "ROBWOT_BACKEND_TOKEN", "NODE_OPTIONS"]) delete env[k];
  const child = spawn("bash", [scriptFile], { cwd: REPO, env, detached: true, stdio: ["ignore", "pipe", "pipe"] });
  let output = "";
  child.stdout.on("data", (d: Buffer) => (output += d.toString()));
  child.stderr.on("data", (d: Buffer) => (output += d.toString()));
  // bash's own exit (background servers keep the pipes open: "close" would wait for them)
  const exited = new Promise<void>((resolve) => child.on("exit", () => resolve()));
  const closed = new Promise<void>((resolve) => child.on("close", () => resolve()));
  let timedOut = false;
  const killGroup = (sig: NodeJS.Signals) => {
    try {
      process.kill(-child.pid!, sig);
    } catch {
      /* group gone */
    }
  };
  const timer = setTimeout(() => {
    timedOut = true;
    killGroup("SIGTERM");
  }, timeoutMs);
  try {
    await exited;
  } finally {
    clearTimeout(timer);
    // background servers the blocks started: SIGTERM (they stop their backends), then SIGKILL
    killGroup("SIGTERM");
    await Promise.race([closed, new Promise((r) => setTimeout(r, 10_000))]);
    killGroup("SIGKILL");
    await closed;
  }
  const entries = readFileSync(log, "utf8").split("\n").filter(Boolean);
  rmSync(dir, { recursive: true, force: true });
  return blocks.map((block, n) => {
    const start = output.indexOf(`${MARK} ${n} start\n`);
    const end = output.indexOf(`${MARK} ${n} end\n`);
    const blockOutput = start < 0 ? "" : output.slice(start + `${MARK} ${n} start\n`.length, end < 0 ? undefined : end);
    const failures: string[] = [];
    if (start < 0 || end < 0) failures.push(timedOut ? `timed out after ${timeoutMs / 1000} s` : "did not run to its end");
    const from = ranges[n]!.from;
    const readmeLine = (scriptLine: number) => block.line + scriptLine - from;
    const commands = commandsOf(block);
    const commandAt = (scriptLine: number) => commands.find((c) => scriptLine - from >= c.first && scriptLine - from <= c.last);
    for (const e of entries) {
      const [kind, a, b] = e.split(" ");
      if (kind === "PRELUDE" && Number(a) === n) failures.push(`prelude (${entryFor(PRELUDES, block)?.reason}) failed with status ${b}`);
      const line = Number(a);
      if (kind === "ERR" && line >= from && line < from + block.text.split("\n").length) {
        const c = commandAt(line);
        failures.push(`${block.file}:${readmeLine(c ? from + c.first : line)}: exit status ${b}: ${c?.text.trim() ?? ""}`);
      }
    }
    // curl answers: the last answer of each curl command (a retry loop's last attempt)
    const answers = new Map<Command, string>();
    for (const e of entries) {
      const [kind, a, status] = e.split(" ");
      if (kind !== "CURL") continue;
      const c = commandAt(Number(a));
      if (c) answers.set(c, status!);
    }
    for (const c of commands) {
      if (!c.curl || c.loop) continue;
      const got = answers.get(c);
      const where = `${block.file}:${block.line + c.first}`;
      if (got === undefined) {
        if (start >= 0 && end >= 0) failures.push(`${where}: curl did not run: ${c.text.trim()}`);
      } else if (c.expectStatus !== null ? got !== String(c.expectStatus) : !/^2\d\d$/.test(got)) {
        failures.push(`${where}: answered ${got}, the README says ${c.expectStatus ?? "nothing (a 2xx)"}: ${c.text.trim()}`);
      }
    }
    const stream = entryFor(STREAM, block);
    if (stream) for (const re of stream.expect) if (!re.test(blockOutput)) failures.push(`${block.file}:${block.line}: output lacks ${re}`);
    return { block, output: blockOutput, failures };
  });
}

// ---------------------------------------------------------------------------------------------------

function docFiles(): string[] {
  const pkgs = readdirSync(join(REPO, "packages"))
    .map((p) => `packages/${p}/README.md`)
    .filter((f) => existsSync(join(REPO, f)))
    .sort();
  const sim = readdirSync(join(REPO, "sim-backend"))
    .filter((f) => f.endsWith(".md"))
    .map((f) => `sim-backend/${f}`)
    .sort();
  return ["README.md", ...pkgs, ...sim];
}

const ALL = docFiles().map((file) => ({ file, blocks: extractBlocks(readFileSync(join(REPO, file), "utf8"), file) }));
const allBlocks = ALL.flatMap((f) => f.blocks);
const TWINS = join(REPO, "twins");
let twinsBefore: Set<string> | undefined;

function portFree(port: number): Promise<boolean> {
  return new Promise((resolve) => {
    const s = createServer();
    s.once("error", () => resolve(false));
    s.listen(port, "127.0.0.1", () => s.close(() => resolve(true)));
  });
}

beforeAll(async () => {
  const runnable = allBlocks.filter((b) => !entryFor(SKIP, b));
  const text = runnable.map((b) => b.text).join("\n") + PRELUDES.map((p) => p.script).join("\n");
  const ports = [...new Set([...text.matchAll(/(?:127\.0\.0\.1:|--port )(\d+)/g)].map((m) => Number(m[1])))];
  const busy: number[] = [];
  for (const p of ports) if (!(await portFree(p))) busy.push(p);
  if (busy.length) throw new Error(`the docs test needs ports ${ports.join(", ")}; busy: ${busy.join(", ")} (a robwot serve or npm start still running?)`);
  twinsBefore = new Set(existsSync(TWINS) ? readdirSync(TWINS) : []);
  const outs = [...new Set([...text.matchAll(/--out (twins\/[\w.-]+)/g)].map((m) => m[1]!))];
  const taken = outs.filter((o) => twinsBefore!.has(o.slice("twins/".length)));
  if (taken.length) throw new Error(`the READMEs' blocks write ${taken.join(", ")}, which exist already: move them away (the test removes what it writes)`);
});

afterAll(() => {
  if (!twinsBefore || !existsSync(TWINS)) return;
  for (const e of readdirSync(TWINS)) if (!twinsBefore.has(e)) rmSync(join(TWINS, e), { recursive: true, force: true });
  if (twinsBefore.size === 0 && readdirSync(TWINS).length === 0) rmSync(TWINS, { recursive: true, force: true });
});

describe("the lists of exceptions match blocks", () => {
  const entries = [...SKIP.map((e) => ["SKIP", e] as const), ...PRELUDES.map((e) => ["PRELUDE", e] as const), ...STREAM.map((e) => ["STREAM", e] as const)];
  it.each(entries.map(([kind, e]) => [kind, e.file, e.match, e] as const))(
    "%s entry of %s matching %j",
    (_kind, _file, _match, e) => {
      expect(
        allBlocks.filter((b) => b.file === e.file && b.text.includes(e.match)),
        `no command block of ${e.file} contains ${JSON.stringify(e.match)}: remove or update the entry`,
      ).not.toHaveLength(0);
    },
  );
  it("finds command blocks", () => {
    expect(allBlocks.length).toBeGreaterThan(5);
  });
});

describe("the runner sees drift", () => {
  it("fails a failing command and a status that is not the README's, and passes what is right", async () => {
    const server = createServer((sock) => {
      sock.once("data", (d: Buffer) => {
        const ok = d.toString().startsWith("GET /ok ");
        sock.end(`HTTP/1.1 ${ok ? "200 OK" : "404 Not Found"}\r\ncontent-length: 2\r\nconnection: close\r\n\r\nhi`);
      });
    });
    await new Promise<void>((r) => server.listen(0, "127.0.0.1", () => r()));
    const port = (server.address() as { port: number }).port;
    try {
      const md = [
        "```sh",
        `curl -s -o /dev/null -w '%{http_code}\\n' http://127.0.0.1:${port}/ok   # 200`,
        `curl -s http://127.0.0.1:${port}/ok`,
        "```",
        "```bash",
        `curl -s -o /dev/null -w '%{http_code}\\n' \\`,
        `     http://127.0.0.1:${port}/renamed   # 200`,
        `curl -s http://127.0.0.1:${port}/gone`,
        "false",
        "echo after",
        "```",
      ].join("\n");
      const [good, bad] = await runBlocks(extractBlocks(md, "SELF.md"), 30_000);
      expect(good!.failures).toEqual([]);
      expect(good!.output).toContain("200");
      expect(bad!.failures).toEqual([
        "SELF.md:9: exit status 1: false",
        expect.stringMatching(/^SELF\.md:6: answered 404, the README says 200/),
        expect.stringMatching(/^SELF\.md:8: answered 404, the README says nothing \(a 2xx\)/),
      ]);
      expect(bad!.output).toContain("after");
    } finally {
      server.close();
    }
  });
});

for (const { file, blocks } of ALL) {
  if (blocks.length === 0) continue;
  describe(`${file}: command blocks run as written`, () => {
    let results: BlockResult[] = [];
    beforeAll(async () => {
      results = await runBlocks(
        blocks.filter((b) => !entryFor(SKIP, b)),
        300_000,
      );
    }, 320_000);
    for (const block of blocks) {
      const skip = entryFor(SKIP, block);
      const title = `${file}:${block.line} ${block.text.split("\n")[0]!.slice(0, 70)}`;
      if (skip) {
        it.skip(`${title} (skipped: ${skip.reason})`, () => {});
        continue;
      }
      it(title, () => {
        const r = results.find((x) => x.block === block);
        expect(r, "not run").toBeDefined();
        expect(r!.failures, `output:\n${r!.output.slice(-4000)}`).toEqual([]);
      });
    }
  });
}

describe("a broken README command fails (the README's own auth block, one path changed)", () => {
  it("reports the line whose answer is not the README's", async () => {
    const block = allBlocks.find((b) => b.file === "README.md" && b.text.includes("--auth basic:u:p &"));
    expect(block).toBeDefined();
    expect(existsSync(join(TWINS, "panda")), "needs twins/panda, made by README.md's session block above").toBe(true);
    const broken = { ...block!, text: block!.text.replace("/panda/properties/motionStatus", "/panda/properties/motionStatu") };
    expect(broken.text).not.toBe(block!.text);
    const [r] = await runBlocks([broken], 180_000);
    expect(r!.failures).toEqual([expect.stringMatching(/^README\.md:\d+: answered 404, the README says 200: curl -s -u u:p /)]);
  }, 200_000);
});
