import { debugState, publishDebug } from "./debug.js";
import { RobwotError } from "@robwot/core/browser";

/** An error the viewer shows to the user; `code` is stable, `details` structured. */
export class ViewerError extends RobwotError {
  override name = "ViewerError";
}

function describe(err: unknown): string {
  if (err instanceof RobwotError) {
    const extra = Object.keys(err.details).length > 0 ? `\n${JSON.stringify(err.details)}` : "";
    return `${err.code}: ${err.message}${extra}`;
  }
  if (err instanceof Error) return `${err.name}: ${err.message}`;
  return String(err);
}

/** Show an error in the page (never only in the console) and record it in the debug state. */
export function showError(context: string, err: unknown): void {
  const text = `${context}: ${describe(err)}`;
  debugState.errors.push(text);
  publishDebug();
  banner(text, "error");
}

/** Show a notice (an event worth seeing, not a failure, e.g. a collision that stopped a motion). */
export function showNotice(context: string, text: string): void {
  banner(`${context}: ${text}`, "error notice");
}

function banner(text: string, className: string): void {
  const box = document.getElementById("errors");
  if (!box) return;
  const div = document.createElement("div");
  div.className = className;
  const close = document.createElement("button");
  close.textContent = "×";
  close.title = "dismiss";
  close.addEventListener("click", () => div.remove());
  div.append(close, document.createTextNode(text));
  box.append(div);
}

/** Route uncaught errors and unhandled rejections into the page too. */
export function installGlobalErrorHandlers(): void {
  window.addEventListener("error", (ev) => showError("uncaught", ev.error ?? ev.message));
  window.addEventListener("unhandledrejection", (ev) => showError("unhandled promise", ev.reason));
}
