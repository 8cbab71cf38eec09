/** Minimal structural types of a W3C WoT Thing Description 1.1 (only what RobWoT produces). */

export interface DataSchema {
  type?: "object" | "array" | "string" | "number" | "integer" | "boolean" | "null";
  title?: string;
  description?: string;
  unit?: string;
  minimum?: number;
  maximum?: number;
  exclusiveMinimum?: number;
  exclusiveMaximum?: number;
  minItems?: number;
  maxItems?: number;
  minLength?: number;
  maxLength?: number;
  enum?: unknown[];
  const?: unknown;
  default?: unknown;
  format?: string;
  readOnly?: boolean;
  writeOnly?: boolean;
  properties?: Record<string, DataSchema>;
  required?: string[];
  additionalProperties?: boolean | DataSchema;
  items?: DataSchema;
  oneOf?: DataSchema[];
}

export interface Form {
  href: string;
  contentType?: string;
  op?: string | string[];
  subprotocol?: string;
  "htv:methodName"?: string;
  [extension: string]: unknown;
}

export interface PropertyAffordance extends DataSchema {
  observable?: boolean;
  forms: Form[];
}

export interface ActionAffordance {
  title?: string;
  description?: string;
  input?: DataSchema;
  output?: DataSchema;
  safe?: boolean;
  idempotent?: boolean;
  synchronous?: boolean;
  uriVariables?: Record<string, DataSchema>;
  forms: Form[];
}

export interface EventAffordance {
  title?: string;
  description?: string;
  data?: DataSchema;
  forms: Form[];
}

export interface Link {
  href: string;
  rel?: string;
  type?: string;
  [extension: string]: unknown;
}

export interface SecurityScheme {
  scheme: "nosec" | "basic" | "bearer" | string;
  in?: string;
  name?: string;
  format?: string;
  alg?: string;
  description?: string;
  [extension: string]: unknown;
}

export interface ThingDescription {
  "@context": [string, ...(string | Record<string, string>)[]];
  "@type"?: string | string[];
  id: string;
  /** W3C WoT Profiles the Thing conforms to (URIs) */
  profile?: string | string[];
  title: string;
  description?: string;
  base?: string;
  securityDefinitions: Record<string, SecurityScheme>;
  security: string | string[];
  properties: Record<string, PropertyAffordance>;
  actions: Record<string, ActionAffordance>;
  events: Record<string, EventAffordance>;
  links: Link[];
  forms?: Form[];
  [extension: string]: unknown;
}
