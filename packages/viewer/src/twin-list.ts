/** The page without `?thing=`: lists the servient's twins from `GET /robwot.json`. */
import { debugState, publishDebug } from "./debug.js";
import { el } from "./dom.js";
import { ViewerError } from "./errors.js";
import { fetchJson, isRecord } from "./http.js";

export interface TwinEntry {
  slug: string;
  title: string;
}

export async function fetchTwinIndex(): Promise<TwinEntry[]> {
  const url = new URL("/robwot.json", location.href).href;
  const index = await fetchJson(url);
  const list = Array.isArray(index)
    ? index
    : isRecord(index)
      ? (index["things"] ?? index["twins"])
      : undefined;
  if (!Array.isArray(list)) {
    throw new ViewerError("E_INDEX", `${url} has no "things" list`, { got: JSON.stringify(index).slice(0, 200) });
  }
  return list.map((t: unknown, i: number) => {
    if (typeof t === "string") return { slug: t, title: t };
    if (isRecord(t) && typeof t["slug"] === "string") {
      return { slug: t["slug"], title: typeof t["title"] === "string" ? t["title"] : t["slug"] };
    }
    throw new ViewerError("E_INDEX", `${url}: entry ${i} has no slug`, { entry: t });
  });
}

export function renderTwinList(parent: HTMLElement, twins: TwinEntry[]): void {
  debugState.phase = "list";
  debugState.twins = twins.map((t) => t.slug);
  publishDebug();
  document.body.classList.add("list");
  const ul = el("ul", { class: "twins" });
  for (const t of twins) {
    ul.append(
      el(
        "li",
        {},
        el("a", { href: `/viewer/?thing=${encodeURIComponent(t.slug)}`, class: "twin" }, t.title),
        " ",
        el("a", { href: `/${encodeURIComponent(t.slug)}`, class: "td", title: "Thing Description" }, "TD"),
      ),
    );
  }
  parent.append(
    el(
      "div",
      { class: "card" },
      el("h1", { text: "RobWoT digital twins" }),
      twins.length > 0 ? ul : el("p", { text: "No twin is served here." }),
      el("p", { class: "hint", text: "Each twin: a live 3D view with its workspace, joint and Cartesian control." }),
    ),
  );
}
