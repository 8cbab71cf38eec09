import { describe, expect, it } from "vitest";
import { RobwotError } from "../errors.js";
import { kukaLikeModel, summaryFixture } from "../test-support/models.js";
import { transformBounds } from "../calibration.js";
import { buildThingDescription, withAbsoluteForms } from "./build.js";
import { securityFor } from "./security.js";
import type { DataSchema } from "./types.js";
import { validateThingDescription } from "./validate.js";

const model = kukaLikeModel();
const summary = summaryFixture();
const td = buildThingDescription({ model, summary, sceneId: "scene-a" });

describe("buildThingDescription", () => {
  it("passes the official TD validator (schema + assertions, JSON-LD off)", async () => {
    const res = await validateThingDescription(td);
    expect(res.errors).toEqual([]);
    expect(res.valid).toBe(true);
    expect(res.report.schema).toBe("passed");
    expect(res.report.additional).toBe("passed");
  });

  it("gives every data schema a type (consumers such as wotpy build typed schemas from it)", () => {
    const untyped: string[] = [];
    const walk = (s: unknown, path: string): void => {
      if (Array.isArray(s)) return s.forEach((x, i) => walk(x, `${path}[${i}]`));
      if (s === null || typeof s !== "object") return;
      const o = s as Record<string, unknown>;
      if (o.type === undefined) untyped.push(path);
      for (const k of ["items", "oneOf"] as const) if (o[k] !== undefined) walk(o[k], `${path}.${k}`);
      for (const [n, x] of Object.entries((o.properties ?? {}) as Record<string, unknown>)) walk(x, `${path}.properties.${n}`);
    };
    for (const [n, p] of Object.entries(td.properties)) walk(p, `properties.${n}`);
    for (const [n, a] of Object.entries(td.actions)) {
      if (a.input) walk(a.input, `actions.${n}.input`);
      if (a.output) walk(a.output, `actions.${n}.output`);
    }
    for (const [n, e] of Object.entries(td.events)) if (e.data) walk(e.data, `events.${n}.data`);
    expect(untyped).toEqual([]);
  });

  it("has context, stable id, base, nosec security and the contract's links", () => {
    expect(td["@context"][0]).toBe("https://www.w3.org/2019/wot/td/v1");
    expect(td["@context"][1]).toBe("https://www.w3.org/2022/wot/td/v1.1");
    expect(td["@context"][2]).toMatchObject({ "@language": "en", robwot: "https://robwot.dev/ns#" });
    expect(td.id).toMatch(/^urn:robwot:lbr_iiwa:[0-9a-f]{16}$/);
    expect(buildThingDescription({ model, summary, sceneId: "scene-a" }).id).toBe(td.id);
    expect(buildThingDescription({ model, summary, sceneId: "scene-b" }).id).not.toBe(td.id);
    expect(td.base).toBe("http://localhost:8080/lbr_iiwa/");
    expect(buildThingDescription({ model, summary, baseUrl: "https://h.example:9000/twins", slug: "arm" }).base).toBe("https://h.example:9000/twins/arm/");
    expect(td.securityDefinitions).toEqual({ nosec_sc: { scheme: "nosec" } });
    expect(td.links).toEqual(
      expect.arrayContaining([
        { rel: "model", href: "robot.urdf", type: "application/urdf+xml" },
        { rel: "workspace-pointcloud", href: "workspace.csv", type: "text/csv" },
        { rel: "workspace", href: "workspace.stl", type: "model/stl" },
      ]),
    );
  });

  it("carries joint limits and units for every controllable joint only", () => {
    const props = td.properties.getJointPosition?.properties ?? {};
    expect(Object.keys(props)).toEqual(model.controllable);
    expect(Object.keys(props)).not.toContain("finger_right");
    expect(Object.keys(props)).not.toContain("tool_fixed");
    expect(props.lbr_iiwa_joint_2).toMatchObject({ type: "number", unit: "rad", minimum: -2.09, maximum: 2.09 });
    expect(props.lift).toMatchObject({ unit: "m", minimum: 0, maximum: 0.25 });
    expect(props.tool_roll).toMatchObject({ unit: "rad", minimum: -Math.PI, maximum: Math.PI });
    const input = td.actions.moveToJointPosition?.input?.properties?.joints;
    expect(input?.properties?.lift).toEqual(props.lift);
    expect(input?.required).toEqual(model.controllable);
  });

  it("bounds Cartesian x, y, z by the reach of the chain (by the sampled points for folders without it)", () => {
    const input = td.actions.moveToCartesianPosition?.input as DataSchema;
    expect(input.required).toEqual(["x", "y", "z"]);
    expect(input.properties?.z).toMatchObject({ unit: "m", minimum: -0.95, maximum: 1.36 });
    const { reachBounds: _unused, ...older } = summary;
    const old = buildThingDescription({ model, summary: older });
    expect((old.actions.moveToCartesianPosition?.input as DataSchema).properties?.z).toMatchObject({ minimum: -0.3, maximum: 1.31 });
    expect(input.properties?.speed).toMatchObject({ minimum: 0.001, maximum: 1 });
    // the pose reading is not bounded: the twin's own states may lie beyond the sampled points
    expect(td.properties.getCartesianPosition?.properties?.x?.minimum).toBeUndefined();
  });

  it("uses node-wot's form layout and ops", () => {
    expect(td.properties.getJointPosition?.forms.slice(0, 2)).toEqual([
      {
        href: "http://localhost:8080/lbr_iiwa/properties/getJointPosition",
        contentType: "application/json",
        op: ["readproperty"],
        "htv:methodName": "GET",
        additionalResponses: [{ success: false, contentType: "application/problem+json", schema: "error" }],
      },
      {
        href: "http://localhost:8080/lbr_iiwa/properties/getJointPosition/observable",
        contentType: "application/json",
        op: ["observeproperty", "unobserveproperty"],
        subprotocol: "longpoll",
      },
    ]);
    expect(td.properties.getJointPosition?.forms).toHaveLength(3);
    expect(td.properties.getJointPosition?.forms[2]).toMatchObject({ subprotocol: "sse", op: ["observeproperty", "unobserveproperty"] });
    expect(td.links).toContainEqual({ rel: "robwot:live", href: "ws://localhost:8080/live", type: "application/json" });
    // absolute hrefs: consumers that do not resolve against base (wotpy) still reach them
    expect(td.actions.stop?.forms).toEqual([
      {
        href: "http://localhost:8080/lbr_iiwa/actions/stop",
        contentType: "application/json",
        op: ["invokeaction"],
        "htv:methodName": "POST",
        // one error answer per status, told apart by the HTTP binding's status code
        additionalResponses: [400, 404, 409, 413, 415, 422, 503, 504].map((status) => ({
          success: false,
          contentType: "application/problem+json",
          schema: "error",
          "htv:statusCodeValue": status,
        })),
      },
    ]);
    // RFC 7807 problem details, with the earlier body's members as extensions
    expect(td.schemaDefinitions?.["error"]).toMatchObject({ type: "object", required: ["type", "title", "status", "detail", "code", "message", "details"] });
    expect(td.events.collision?.forms[0]).toMatchObject({ href: "http://localhost:8080/lbr_iiwa/events/collision", op: ["subscribeevent", "unsubscribeevent"] });
    const names = [...Object.keys(td.properties), ...Object.keys(td.actions), ...Object.keys(td.events)];
    for (const n of ["getJointPosition", "getCartesianPosition", "moveToJointPosition", "moveToCartesianPosition", "validateCartesianPosition", "calibrate", "collision", "motionStatus"]) {
      expect(names).toContain(n);
    }
    expect(buildThingDescription({ model, summary, liveUrl: null }).links.map((l) => l.rel)).not.toContain("robwot:live");
  });

  it("offers the move actions asynchronously: a Prefer: respond-async form, queryaction and cancelaction on the ActionStatus template", () => {
    const base = "http://localhost:8080/lbr_iiwa/";
    for (const name of ["moveToJointPosition", "moveToCartesianPosition"]) {
      const a = td.actions[name]!;
      const forms = a.forms;
      // the synchronous form stays first: node-wot and wotpy pick the first invokeaction / http form
      expect(forms[0]).toEqual({ ...td.actions.stop?.forms[0], href: `${base}actions/${name}` });
      expect(forms[1]).toMatchObject({
        href: `${base}actions/${name}`,
        op: ["invokeaction"],
        "htv:methodName": "POST",
        "htv:headers": [{ "htv:fieldName": "Prefer", "htv:fieldValue": "respond-async" }],
        response: { contentType: "application/json", "htv:statusCodeValue": 201 },
      });
      expect(forms[1]?.additionalResponses).toContainEqual({ success: true, contentType: "application/json", schema: "actionStatus", "htv:statusCodeValue": 201 });
      // the template's braces survive the absolute hrefs (URL would percent-encode them)
      expect(forms.slice(2).map((f) => [f.href, f.op, f["htv:methodName"]])).toEqual([
        [`${base}actions/${name}/{actionID}`, ["queryaction"], "GET"],
        [`${base}actions/${name}/{actionID}`, ["cancelaction"], "DELETE"],
      ]);
      expect(a.uriVariables).toEqual({ actionID: expect.objectContaining({ type: "string" }) });
    }
    for (const name of ["validateJointPosition", "stop", "calibrate", "addObstacle"]) {
      expect(td.actions[name]?.forms.flatMap((f) => f.op)).toEqual(["invokeaction"]);
      expect(td.actions[name]?.uriVariables).toBeUndefined();
    }
    const status = td.schemaDefinitions as Record<string, DataSchema>;
    // the WoT Profile's four values: a cancelled invocation has no status (its resource is deleted)
    expect(status.actionStatus?.properties?.status?.enum).toEqual(["pending", "running", "completed", "failed"]);
    expect(td.actions.moveToJointPosition?.forms[3]?.response).toEqual({ contentType: "application/json", "htv:statusCodeValue": 204 });
    expect(status.actionStatus?.properties?.output).toEqual(td.actions.moveToJointPosition?.output);
    expect(status.actionStatus?.required).toEqual(["status", "progress", "href", "id", "timeRequested"]);
    // moved to another address, the template moves with the other forms
    const moved = withAbsoluteForms(structuredClone(td), "https://twin.example:9443/arm/");
    expect(moved.actions.moveToJointPosition?.forms[2]?.href).toBe("https://twin.example:9443/arm/actions/moveToJointPosition/{actionID}");
  });

  it("declares the WoT Profiles, the TD 1.1 context they need, and synchronous on every action", () => {
    expect(td.profile).toEqual(["https://www.w3.org/2022/wot/profile/http-basic/v1", "https://www.w3.org/2022/wot/profile/http-sse/v1"]);
    expect(td["@context"]).toContain("https://www.w3.org/2022/wot/td/v1.1");
    for (const [name, a] of Object.entries(td.actions)) expect(a.synchronous, name).toBe(true);
    const basic = securityFor(td, { scheme: "basic" });
    expect(basic.securityDefinitions).toEqual({ basic_sc: { scheme: "basic", in: "header", name: "Authorization" } });
  });

  it("maps Cartesian bounds through an active calibration", () => {
    const rotZ90 = [[0, -1, 0], [1, 0, 0], [0, 0, 1]];
    const b = transformBounds(summary.reachBounds!, { scale: 2, rotation: rotZ90, translation: [1, 0, 0] });
    expect(b.min[0]).toBeCloseTo(1 - 2 * 1.2);
    expect(b.max[1]).toBeCloseTo(2 * 1.2);
    const cal = buildThingDescription({ model, summary, calibration: { scale: 2, rotation: rotZ90, translation: [1, 0, 0] } });
    const input = cal.actions.moveToCartesianPosition?.input as DataSchema;
    expect(input.properties?.x?.minimum).toBeCloseTo(b.min[0]);
  });

  it.each([
    ["unknown controllable joint", { ...model, controllable: ["nope"] }, /nope/],
    ["no controllable joint", { ...model, controllable: [] }, /no controllable/],
    ["inverted limits", { ...model, joints: model.joints.map((j) => (j.name === "lift" ? { ...j, lower: 1, upper: 0 } : j)) }, /lift/],
  ])("rejects %s", (_label, bad, message) => {
    expect(() => buildThingDescription({ model: bad, summary })).toThrow(message);
    try {
      buildThingDescription({ model: bad, summary });
    } catch (e) {
      expect(e).toBeInstanceOf(RobwotError);
      expect((e as RobwotError).code).toBe("E_TD");
    }
  });

  it("rejects a relative base URL", () => {
    expect(() => buildThingDescription({ model, summary, baseUrl: "localhost:8080" })).toThrow(/baseUrl/);
  });
});

describe("securityFor", () => {
  it.each([
    [{ scheme: "basic" as const }, "basic_sc", "basic"],
    [{ scheme: "bearer" as const }, "bearer_sc", "bearer"],
    [null, "nosec_sc", "nosec"],
  ])("rewrites security for %j", async (auth, name, scheme) => {
    const out = securityFor(td, auth);
    expect(out.security).toBe(name);
    expect(Object.keys(out.securityDefinitions)).toEqual([name]);
    expect(out.securityDefinitions[name]?.scheme).toBe(scheme);
    expect(td.security).toBe("nosec_sc");
    expect((await validateThingDescription(out)).valid).toBe(true);
  });
});

describe("validateThingDescription", () => {
  it("detects a property without forms", async () => {
    const bad = structuredClone(td) as unknown as { properties: Record<string, Record<string, unknown>> };
    delete bad.properties.getJointPosition?.forms;
    const res = await validateThingDescription(bad);
    expect(res.valid).toBe(false);
    expect(res.errors.join(" ")).toMatch(/forms/);
  });

  it.each([
    ["undefined security name", { security: "missing_sc" }],
    ["missing title", { title: undefined }],
    ["wrong context", { "@context": "https://example.org/ctx" }],
  ])("detects %s", async (_label, patch) => {
    const res = await validateThingDescription({ ...td, ...patch });
    expect(res.valid).toBe(false);
    expect(res.errors.length).toBeGreaterThan(0);
  });
});
