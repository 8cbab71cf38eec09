/**
 * `robwot openapi` on a generated twin: the official converter rejects its own output for the TD
 * (nested TD terms it copies verbatim); the command's corrected document is valid OpenAPI 3.0 and
 * states the TD's schemas, error answers and server.
 */
import { mkdtempSync, readFileSync, rmSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { Validator } from "@seriousme/openapi-schema-validator";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { thingOpenApi } from "../packages/cli/src/openapi.js";
import { runCli } from "./cli-run.js";
import { generateTwin } from "./serve-helpers.js";

const require = createRequire(join(import.meta.dirname, "..", "packages", "cli", "package.json"));
let twin: string;
let work: string;
let td: any;
let doc: any;

beforeAll(async () => {
  twin = await generateTwin("kuka_iiwa", 3000);
  work = mkdtempSync(join(tmpdir(), "robwot-openapi-"));
  td = JSON.parse(readFileSync(join(twin, "td.json"), "utf8"));
  const r = await runCli(["openapi", twin, "--out", join(work, "openapi.json"), "--base", "http://127.0.0.1:9123"]);
  expect(r.code, r.stderr).toBe(0);
  doc = JSON.parse(readFileSync(join(work, "openapi.json"), "utf8"));
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

describe("robwot openapi", () => {
  it("states both answers of a move (200 synchronous, 201 ActionStatus with Prefer: respond-async) and its status resource", () => {
    const slug = new URL(td.base).pathname.split("/").filter(Boolean).pop();
    for (const name of ["moveToJointPosition", "moveToCartesianPosition"]) {
      const post = doc.paths[`/${slug}/actions/${name}`].post;
      expect(Object.keys(post.responses)).toEqual(expect.arrayContaining(["200", "201"]));
      const created = post.responses["201"];
      expect(created.content["application/json"].schema).toEqual({ $ref: "#/components/schemas/actionStatus" });
      // RFC 7240: unknown preferences are ignored, so Prefer is any string (respond-async its example)
      expect(post.parameters).toEqual([expect.objectContaining({ name: "Prefer", in: "header", required: false, schema: { type: "string" }, example: "respond-async" })]);
      // the 201's Location, and links a stateful client follows to the status resource
      expect(created.headers.Location).toMatchObject({ required: true, schema: { type: "string", format: "uri" } });
      expect(created.links).toEqual({
        queryaction: expect.objectContaining({ operationId: `queryaction_${name}`, parameters: { actionID: "$response.body#/id" } }),
        cancelaction: expect.objectContaining({ operationId: `cancelaction_${name}`, parameters: { actionID: "$response.body#/id" } }),
      });
      const item = doc.paths[`/${slug}/actions/${name}/{actionID}`];
      expect([item.get.operationId, item.delete.operationId]).toEqual([`queryaction_${name}`, `cancelaction_${name}`]);
      for (const method of ["get", "delete"]) {
        expect(item[method].parameters, `${name} ${method}`).toEqual([expect.objectContaining({ name: "actionID", in: "path", required: true })]);
        expect(item[method].requestBody).toBeUndefined();
      }
      expect(item.get.responses["200"].content["application/json"].schema).toEqual({ $ref: "#/components/schemas/actionStatus" });
      // the WoT Profile's cancel: 204 without a body; 409 when the move had already ended
      expect(item.delete.responses["204"]).toEqual({ description: expect.any(String) });
      expect(item.delete.responses["200"]).toBeUndefined();
      expect(item.delete.responses["409"].content["application/problem+json"].schema).toEqual({ $ref: "#/components/schemas/error" });
    }
    expect(JSON.stringify(doc)).not.toContain('"in":"query"'); // the action's uriVariable is a path parameter only
  });

  it("--base naming the Thing itself (http://host/<slug>/) does not repeat the slug in the paths", async () => {
    const slug = new URL(td.base).pathname.split("/").filter(Boolean).pop()!;
    for (const base of [`http://127.0.0.1:9123/${slug}/`, `http://127.0.0.1:9123/${slug}`]) {
      const named = await thingOpenApi(td, { base });
      expect(Object.keys(named.paths as object)).toEqual(Object.keys(doc.paths));
      expect(named.servers).toEqual(doc.servers);
    }
    // behind a path prefix: the prefix stays, the slug once
    const prefixed = await thingOpenApi(td, { base: "http://127.0.0.1:9123/robots/" });
    expect(Object.keys(prefixed.paths as object)).toContain(`/robots/${slug}/actions/stop`);
    expect(Object.keys(prefixed.paths as object).some((p) => p.includes(`${slug}/${slug}`))).toBe(false);
  });

  it("the official converter alone rejects its output for the TD (why the command corrects it)", async () => {
    const toOpenAPI = require("@thing-description-playground/td_to_openapi") as (td: unknown) => Promise<unknown>;
    await expect(toOpenAPI(structuredClone(td))).rejects.toThrow(/unit|exclusiveMinimum|const|schema validation failed/i);
  });

  it("writes a document valid against the OpenAPI 3.0 schema", async () => {
    const result = await new Validator().validate(doc);
    expect(result.errors ?? [], JSON.stringify(result.errors)).toEqual([]);
    expect(result.valid).toBe(true);
    expect(doc.openapi).toMatch(/^3\.0\./);
    expect(doc.servers).toEqual([expect.objectContaining({ url: "http://127.0.0.1:9123" })]);
  });

  it("has one operation per HTTP form of the TD, each with its complete schemas", () => {
    const slug = new URL(td.base).pathname.split("/").filter(Boolean).pop();
    for (const name of Object.keys(td.actions)) {
      const op = doc.paths[`/${slug}/actions/${name}`]?.post;
      expect(op, name).toBeDefined();
      const input = td.actions[name].input;
      if (input) {
        const req = op.requestBody.content["application/json"].schema;
        expect(req.required ?? [], name).toEqual(input.required ?? []);
        // the converter drops a top-level additionalProperties: the inputs are closed again
        expect(req.additionalProperties, name).toBe(false);
      } else {
        expect(op.requestBody, name).toBeUndefined();
      }
      expect(op.responses["200"].content["application/json"].schema.required ?? [], name).toEqual(td.actions[name].output?.required ?? []);
      // one response per error status the TD lists, with the error body; no catch-all
      for (const status of [400, 404, 409, 413, 415, 422, 503, 504]) {
        expect(op.responses[String(status)].content["application/problem+json"].schema, `${name} ${status}`).toEqual({ $ref: "#/components/schemas/error" });
      }
      expect(op.responses.default, name).toBeUndefined();
    }
    for (const name of Object.keys(td.properties)) {
      const op = doc.paths[`/${slug}/properties/${name}`]?.get;
      expect(op.responses["200"].content["application/json"].schema.required, name).toEqual(td.properties[name].required);
    }
    // an event's long-poll answer is its data; readallproperties names every property
    expect(doc.paths[`/${slug}/events/collision`].get.responses["200"].content["application/json"].schema.required).toEqual(td.events.collision.data.required);
    expect(doc.paths[`/${slug}/properties`].get.responses["200"].content["application/json"].schema.required).toEqual(Object.keys(td.properties));
    expect(doc.components.schemas.error.required).toEqual(["type", "title", "status", "detail", "code", "message", "details"]);
    // TD terms without an OpenAPI keyword survive as extensions; numeric exclusive bounds are translated
    const joint = doc.paths[`/${slug}/properties/getJointPosition`].get.responses["200"].content["application/json"].schema.properties.lbr_iiwa_joint_1;
    expect(joint["x-unit"]).toBe("rad");
    const text = JSON.stringify(doc);
    expect(text).not.toMatch(/"unit":|"const":|"exclusiveMinimum":\d/);
  });

  it("writes the whole document to a pipe without --out (it is ~200 kB: no cut at exit)", async () => {
    const r = await runCli(["openapi", twin, "--base", "http://127.0.0.1:9123"]);
    expect(r.code, r.stderr).toBe(0);
    expect(JSON.parse(r.stdout)).toEqual(doc);
  });

  it("has a text/event-stream GET per Server-Sent Events form, which the converter leaves out", () => {
    const sse = Object.keys(doc.paths).filter((p) => p.endsWith("/sse"));
    const forms = [...Object.values(td.properties), ...Object.values(td.events)].flatMap((a: any) => a.forms).filter((f: any) => f.subprotocol === "sse");
    expect(sse.sort()).toEqual(forms.map((f: any) => new URL(f.href).pathname).sort());
    const stream = doc.paths[sse.find((p) => p.includes("getJointPosition"))!].get.responses["200"].content["text/event-stream"].schema;
    expect(stream["x-data-schema"].required).toEqual(td.properties.getJointPosition.required);
  });

  it("names the file and the option in its errors", async () => {
    const missing = await runCli(["openapi", join(work, "nope")]);
    expect(missing.code).toBe(1);
    expect(missing.stderr).toMatch(/robwot: error: twin folder not found: .*nope/);
    const empty = await runCli(["openapi", work]);
    expect(empty.stderr).toMatch(/is not a twin folder: no td\.json/);
    const base = await runCli(["openapi", twin, "--base", "ftp://x"]);
    expect(base.code).toBe(2);
    expect(base.stderr).toMatch(/--base must use http or https/);
    // a document is read by others: credentials in its base would be published
    const secret = await runCli(["openapi", twin, "--base", "http://u:pw@127.0.0.1:9123/"]);
    expect(secret.code).toBe(2);
    expect(secret.stderr).toMatch(/--base must not carry credentials/);
    expect(secret.stdout).not.toContain("pw");
    const help = await runCli(["openapi", "--help"]);
    expect(help.stdout).toMatch(/Usage: robwot openapi <twin-folder>/);
  });
});

describe("thingOpenApi on a TD whose error answers carry no status (twin folders of earlier versions)", () => {
  it("keeps one catch-all error answer with the error body", async () => {
    const old = structuredClone(td);
    for (const a of Object.values(old.actions) as any[]) a.forms[0].additionalResponses = [{ success: false, contentType: "application/json", schema: "error" }];
    const d: any = await thingOpenApi(old);
    const responses = d.paths[new URL(old.actions.stop.forms[0].href).pathname].post.responses;
    expect(Object.keys(responses).sort()).toEqual(["200", "default"]);
    expect(responses.default.content["application/json"].schema).toEqual({ $ref: "#/components/schemas/error" });
    // without --base the server is the origin of the TD's own base
    expect(d.servers[0].url).toBe(new URL(old.base).origin);
  });
});

describe("thingOpenApi, other TD shapes", () => {
  it("is deterministic: the same TD gives the same document (no random examples)", async () => {
    expect(JSON.stringify(await thingOpenApi(td))).toBe(JSON.stringify(await thingOpenApi(td)));
    // the one example is the value a form states (the Prefer header's), none faked
    expect(JSON.stringify(doc).match(/"example":[^,}]*/g)?.every((e) => e === '"example":"respond-async"')).toBe(true);
  });

  it("answers with the status and type of a form's `response` when it names them", async () => {
    const other = structuredClone(td);
    other.actions.stop.forms[0].response = { contentType: "application/json", "htv:statusCodeValue": 201 };
    const d: any = await thingOpenApi(other);
    const responses = d.paths[new URL(other.actions.stop.forms[0].href).pathname].post.responses;
    expect(responses["200"]).toBeUndefined();
    expect(responses["201"].content["application/json"].schema.required).toEqual(["stopped", "simulation"]);
  });
});
