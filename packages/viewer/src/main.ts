/** Entry point: `?thing=<slug>` shows that twin; without it, the list of twins served here. */
import { debugState, publishDebug } from "./debug.js";
import { installGlobalErrorHandlers, showError } from "./errors.js";
import { fetchTwinIndex, renderTwinList } from "./twin-list.js";
import { showTwin } from "./twin-page.js";

installGlobalErrorHandlers();
publishDebug();

async function main(): Promise<void> {
  const content = document.getElementById("content");
  const view = document.getElementById("view");
  if (!content || !view) throw new Error("index.html lacks #content or #view");
  const slug = new URLSearchParams(location.search).get("thing");
  if (slug === null || slug === "") {
    renderTwinList(view, await fetchTwinIndex());
    return;
  }
  await showTwin(slug, view, content);
}

main().catch((err: unknown) => {
  debugState.phase = "error";
  showError("viewer", err);
});
