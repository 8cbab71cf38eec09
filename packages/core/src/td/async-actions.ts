/**
 * Asynchronous move actions (W3C WoT Profile, HTTP Basic Profile, "Asynchronous Action Response").
 *
 * How a client chooses: an invocation is synchronous unless its request carries `Prefer: respond-async`
 * (RFC 7240). Synchronous (the default, what node-wot's and wotpy's `invokeAction` expect): `200` with
 * the action's output once the motion has ended. Asynchronous: `201 Created`, `Location` = the URL of an
 * ActionStatus resource, `Preference-Applied: respond-async`, and the ActionStatus as body; then `GET`
 * on that URL (queryaction) answers the current ActionStatus and `DELETE` (cancelaction) stops the move
 * and answers `204`; as the Profile says, a cancelled invocation's ActionStatus is deleted (then `404`).
 * A DELETE that cancels nothing (the move had already ended) answers `409` and leaves the status as it is.
 *
 * In the TD, each asynchronous action has: its synchronous `invokeaction` form first (consumers pick the
 * first), a second `invokeaction` form that states the `Prefer` header (`htv:headers`) and the 201
 * answer, and `queryaction` / `cancelaction` forms on the URI template `actions/<name>/{actionID}`
 * (`uriVariables.actionID` on the action). Their ActionStatus is `schemaDefinitions.actionStatus`.
 */
import type { ActionAffordance, DataSchema, Form } from "./types.js";

/** The long move actions that also answer asynchronously (and have query/cancel forms). */
export const ASYNC_ACTIONS: readonly string[] = ["moveToJointPosition", "moveToCartesianPosition", "runProgram"];
/** The URI variable naming an ActionStatus resource in the queryaction / cancelaction forms. */
export const ACTION_ID_VARIABLE = "actionID";
/** Name of the ActionStatus data schema in the TD's `schemaDefinitions`. */
export const ACTION_STATUS_SCHEMA = "actionStatus";
/** RFC 7240 preference of an asynchronous invocation. */
export const RESPOND_ASYNC = "respond-async";
/** The WoT Profile's ActionStatus values, no more (a cancelled invocation has no status: it is deleted). */
export const ACTION_STATUSES = ["pending", "running", "completed", "failed"] as const;
export type ActionStatusValue = (typeof ACTION_STATUSES)[number];

const JSON_TYPE = "application/json";

/** The ActionStatus object (WoT Profile) of an asynchronous invocation; `output` = the action's output. */
export function actionStatusSchema(output: DataSchema, error: DataSchema): DataSchema {
  const time = (description: string): DataSchema => ({ type: "string", format: "date-time", description });
  return {
    type: "object",
    description:
      "Status of an asynchronous invocation (W3C WoT Profile ActionStatus): pending (accepted; validation, IK and path planning), " +
      "running (the motion), then completed (output = the result the synchronous invocation answers, also for a motion ended by " +
      "`stop` or a collision) or failed (error = the problem details the synchronous invocation answers); DELETE on href " +
      "cancels (204) and deletes it",
    properties: {
      status: { type: "string", enum: [...ACTION_STATUSES] },
      progress: {
        type: "number",
        minimum: 0,
        maximum: 1,
        description: "share of the planned motion done (simulated time / planned duration); 0 before the motion starts, 1 once the target is reached",
      },
      step: { type: "integer", minimum: 0, description: "runProgram: index of the step running (then the one it ended in)" },
      output,
      error: { ...error, description: "why it failed: the RFC 7807 problem details the synchronous invocation answers" },
      href: { type: "string", description: "URL of this ActionStatus resource (queryaction: GET, cancelaction: DELETE)" },
      id: { type: "string", description: `the last segment of href: the {${ACTION_ID_VARIABLE}} of the queryaction and cancelaction forms` },
      timeRequested: time("when the invocation was received"),
      timeEnded: time("when it completed or failed"),
    },
    required: ["status", "progress", "href", "id", "timeRequested"],
  };
}

/** The forms of an asynchronous action, after its synchronous `invokeaction` form (`sync`). */
export function asyncActionForms(name: string, sync: Form, errors: object[]): Form[] {
  const status = (code: number) => ({ success: true, contentType: JSON_TYPE, schema: ACTION_STATUS_SCHEMA, "htv:statusCodeValue": code });
  const resource = `actions/${name}/{${ACTION_ID_VARIABLE}}`;
  return [
    {
      ...sync,
      "htv:headers": [{ "htv:fieldName": "Prefer", "htv:fieldValue": RESPOND_ASYNC }],
      response: { contentType: JSON_TYPE, "htv:statusCodeValue": 201 },
      additionalResponses: [status(201), ...errors],
    },
    { href: resource, contentType: JSON_TYPE, op: ["queryaction"], "htv:methodName": "GET", additionalResponses: [status(200), ...errors] },
    {
      href: resource,
      contentType: JSON_TYPE,
      op: ["cancelaction"],
      "htv:methodName": "DELETE",
      response: { contentType: JSON_TYPE, "htv:statusCodeValue": 204 },
      // among the errors, 409: the invocation had already ended (nothing cancelled; its status stays queryable)
      additionalResponses: errors,
    },
  ];
}

/** The `uriVariables` of an asynchronous action (the ActionStatus id of its query/cancel forms). */
export function asyncActionVariables(): NonNullable<ActionAffordance["uriVariables"]> {
  return { [ACTION_ID_VARIABLE]: { type: "string", description: "id of an ActionStatus resource: the last segment of the Location of a 201 answer" } };
}
