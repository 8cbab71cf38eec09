/**
 * Relay (`--relay <TD URL>`): after the twin has validated and performed a command, the same command
 * (Cartesian targets in the real frame, i.e. already "mapped through the calibration") is sent to the
 * physical robot's Thing, consumed with node-wot. A failure there is reported in the move result
 * (`relay: {ok: false, error}`) and in motionStatus.lastError (`E_RELAY`), never hidden.
 */

/** The part of node-wot's WoT API the relay needs. */
export interface WoTLike {
  requestThingDescription(url: string): Promise<unknown>;
  consume(td: unknown): Promise<ConsumedLike>;
}

interface ConsumedLike {
  invokeAction(name: string, input?: unknown): Promise<{ value(): Promise<unknown> } | undefined>;
}

export interface RelayReport {
  ok: boolean;
  target: string;
  action: string;
  result?: unknown;
  error?: string;
}

export class Relay {
  private thing: ConsumedLike | null = null;

  constructor(
    private readonly wot: WoTLike,
    readonly url: string,
  ) {}

  /** Fetches and consumes the physical robot's TD (also retried lazily by `forward`). */
  async connect(): Promise<void> {
    const td = await this.wot.requestThingDescription(this.url);
    this.thing = await this.wot.consume(td);
  }

  async forward(action: string, input: unknown): Promise<RelayReport> {
    const base = { target: this.url, action };
    try {
      if (!this.thing) await this.connect();
      const out = await (this.thing as ConsumedLike).invokeAction(action, input);
      const result = out ? await out.value() : undefined;
      const status = (result as { status?: unknown } | undefined)?.status;
      if (typeof status === "string" && status !== "reached" && action !== "stop") {
        return { ...base, ok: false, result, error: `physical robot ended its motion with status "${status}"` };
      }
      return { ...base, ok: true, result };
    } catch (err) {
      return { ...base, ok: false, error: err instanceof Error ? err.message : String(err) };
    }
  }
}
