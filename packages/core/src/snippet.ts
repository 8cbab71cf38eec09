/**
 * Quoting untrusted file content in error messages: errors go to logs, terminals and HTTP clients, so
 * they carry at most a short, printable piece of the file they are about, never its bulk. Pure
 * (browser-safe).
 */

/** At most `max` characters of `text`, printable ASCII only (anything else as `?`), `...` when cut. */
export function snippet(text: unknown, max = 32): string {
  const s = String(text);
  let out = "";
  for (const ch of s.slice(0, max)) out += ch >= " " && ch <= "~" && ch !== "'" ? ch : "?";
  return s.length > max ? `${out}...` : out;
}

/**
 * Where a `JSON.parse` error happened, without its message (V8 quotes the start of the text in it):
 * ` at line L, column C` when the engine gives a position, else "".
 */
export function jsonErrorAt(err: unknown, text: string): string {
  const m = /at position (\d+)/.exec(err instanceof Error ? err.message : "");
  if (!m) return "";
  const pos = Math.min(Number(m[1]), text.length);
  const before = text.slice(0, pos);
  const line = before.split("\n").length;
  return ` at line ${line}, column ${pos - before.lastIndexOf("\n")}`;
}
