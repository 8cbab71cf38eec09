/**
 * One HTTP request with exactly the given headers, Host included (fetch forbids setting Host): what a
 * rebound DNS name or a hand-made client sends. The answer's body is parsed as JSON where it is JSON.
 */
import { request } from "node:http";

export interface RawAnswer {
  status: number;
  headers: Record<string, string | string[] | undefined>;
  body: any;
}

/** `method path` to 127.0.0.1:`port`; Host defaults to `127.0.0.1:<port>`, `headers` override it. */
export function rawRequest(port: number, method: string, path: string, headers: Record<string, string>, body?: string): Promise<RawAnswer> {
  return new Promise((resolve, reject) => {
    // a body is framed by its length: Node's client sends a DELETE's body unframed, which the server would
    // parse as a second request
    const length: Record<string, string> = body !== undefined ? { "content-length": String(Buffer.byteLength(body)) } : {};
    const req = request({ host: "127.0.0.1", port, method, path, headers: { host: `127.0.0.1:${port}`, ...length, ...headers } }, (res) => {
      const chunks: Buffer[] = [];
      res.on("data", (c: Buffer) => chunks.push(c));
      res.on("end", () => {
        const text = Buffer.concat(chunks).toString("utf8");
        let parsed: unknown = text;
        try {
          parsed = JSON.parse(text);
        } catch {
          /* not JSON */
        }
        resolve({ status: res.statusCode ?? 0, headers: res.headers, body: parsed });
      });
    });
    req.on("error", reject);
    if (body !== undefined) req.write(body);
    req.end();
  });
}
