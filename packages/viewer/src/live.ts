/**
 * Live state over the servient's `/live` WebSocket (Contract 4): send `{"subscribe": slug}`, receive
 * `{thing, type: "joints" | "status" | "collision" | "scene" | "physical" | "divergence", ...}`. The newest joint message wins; the render loop
 * picks it up at display rate. Reconnects with back-off and reports the connection state.
 */
import { ViewerError } from "./errors.js";
import { isRecord } from "./http.js";

export interface LiveHandlers {
  joints(joints: Record<string, number>, msg: Record<string, unknown>): void;
  status(msg: Record<string, unknown>): void;
  collision(msg: Record<string, unknown>): void;
  /** `{type: "scene", obstacles}`: the shared world's obstacles after a run-time edit (and on subscribe). */
  scene(msg: Record<string, unknown>): void;
  /** `{type: "physical", ...physicalState}`: a reading of the physical robot the twin follows. */
  physical?(msg: Record<string, unknown>): void;
  /** `{type: "divergence", joint, tcp, time, bound, joints, expected}`: a relayed move passed the divergence bound. */
  divergence?(msg: Record<string, unknown>): void;
  connection(open: boolean): void;
  error(err: ViewerError): void;
}

export class LiveClient {
  private socket: WebSocket | null = null;
  private retryMs = 500;
  private closed = false;
  /** One message per outage, not one per retry. */
  private outageReported = false;

  constructor(
    private readonly url: string,
    private readonly slug: string,
    private readonly handlers: LiveHandlers,
  ) {}

  connect(): void {
    const ws = new WebSocket(this.url);
    this.socket = ws;
    ws.addEventListener("open", () => {
      this.retryMs = 500;
      this.outageReported = false;
      ws.send(JSON.stringify({ subscribe: this.slug }));
      this.handlers.connection(true);
    });
    ws.addEventListener("message", (ev) => this.onMessage(ev.data));
    ws.addEventListener("close", (ev) => {
      this.handlers.connection(false);
      if (this.closed) return;
      if (!this.outageReported && ev.code !== 1000) {
        this.outageReported = true;
        this.handlers.error(
          new ViewerError("E_LIVE", `live connection ${this.url} lost (close code ${ev.code}${ev.reason ? `: ${ev.reason}` : ""}); reconnecting in the background`, {
            url: this.url,
          }),
        );
      }
      window.setTimeout(() => this.connect(), this.retryMs);
      this.retryMs = Math.min(this.retryMs * 2, 10_000);
    });
  }

  close(): void {
    this.closed = true;
    this.socket?.close(1000);
  }

  private onMessage(data: unknown): void {
    let msg: unknown;
    try {
      msg = JSON.parse(String(data));
    } catch {
      this.handlers.error(new ViewerError("E_LIVE", "live message is not JSON", { got: String(data).slice(0, 120) }));
      return;
    }
    if (!isRecord(msg)) return;
    if (msg["thing"] !== undefined && msg["thing"] !== this.slug) return;
    switch (msg["type"]) {
      case "joints": {
        const joints = msg["joints"];
        if (isRecord(joints) && Object.values(joints).every((v) => typeof v === "number")) {
          this.handlers.joints(joints as Record<string, number>, msg);
        } else this.handlers.error(new ViewerError("E_LIVE", "joints message without numeric joints", { msg }));
        return;
      }
      case "status":
        this.handlers.status(msg);
        return;
      case "collision":
        this.handlers.collision(msg);
        return;
      case "scene":
        this.handlers.scene(msg);
        return;
      case "physical":
        this.handlers.physical?.(msg);
        return;
      case "divergence":
        this.handlers.divergence?.(msg);
        return;
      case "error":
        this.handlers.error(new ViewerError("E_LIVE", String(msg["message"] ?? "live error"), { msg }));
        return;
      default:
        return; // other message kinds (subscribed acks, future types) are not for the view
    }
  }
}
