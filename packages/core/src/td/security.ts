/** Rewrites a TD's security for the servient's `--auth` option. */
import type { SecurityScheme, ThingDescription } from "./types.js";

export type AuthScheme = { scheme: "basic" } | { scheme: "bearer" };

/** Returns a copy of `td` whose securityDefinitions/security say nosec (auth null), basic or bearer (in header). */
export function securityFor(td: ThingDescription, auth: AuthScheme | null): ThingDescription {
  let name: string;
  let def: SecurityScheme;
  if (auth === null) {
    name = "nosec_sc";
    def = { scheme: "nosec" };
  } else if (auth.scheme === "basic") {
    name = "basic_sc";
    // WoT Profile: a basic scheme names its header ("Authorization"; "Proxy-Authorization" only behind a proxy)
    def = { scheme: "basic", in: "header", name: "Authorization" };
  } else {
    name = "bearer_sc";
    def = { scheme: "bearer", in: "header" };
  }
  return { ...td, securityDefinitions: { [name]: def }, security: name };
}
