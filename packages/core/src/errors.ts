/**
 * Errors of @robwot/core. Every error carries a stable string `code` (E_...) and a structured
 * `details` object naming the file / line / joint / value / limit involved, so callers (CLI,
 * servient) can map it to exit codes or HTTP 400 JSON bodies without parsing messages.
 */
export type ErrorDetails = Record<string, unknown>;

export class RobwotError extends Error {
  override name = "RobwotError";
  readonly code: string;
  readonly details: ErrorDetails;

  constructor(code: string, message: string, details: ErrorDetails = {}, options?: { cause?: unknown }) {
    super(message, options);
    this.code = code;
    this.details = details;
  }

  /** Plain JSON form `{code, message, details}` (the servient's 4xx body). */
  toJSON(): { code: string; message: string; details: ErrorDetails } {
    return { code: this.code, message: this.message, details: this.details };
  }
}

/** Malformed workspace CSV (details: file, line, column?, value?). */
export class CsvError extends RobwotError {
  override name = "CsvError";
  constructor(message: string, details: ErrorDetails = {}) {
    super("E_BAD_CSV", message, details);
  }
}

/** Malformed or truncated STL (details: file?, offset?, line?). */
export class StlError extends RobwotError {
  override name = "StlError";
  constructor(message: string, details: ErrorDetails = {}) {
    super("E_BAD_STL", message, details);
  }
}

/** Calibration input unusable: too few pairs, non-finite values, degenerate geometry. */
export class CalibrationError extends RobwotError {
  override name = "CalibrationError";
  constructor(message: string, details: ErrorDetails = {}) {
    super("E_CALIBRATION", message, details);
  }
}

/** Bad input to the TD builder (details: field, value). */
export class ThingDescriptionError extends RobwotError {
  override name = "ThingDescriptionError";
  constructor(message: string, details: ErrorDetails = {}) {
    super("E_TD", message, details);
  }
}

/** A function got an argument of the wrong shape (details: param, expected, got). */
export class InvalidArgumentError extends RobwotError {
  override name = "InvalidArgumentError";
  constructor(message: string, details: ErrorDetails = {}) {
    super("E_INVALID_ARGUMENT", message, details);
  }
}

/** A file (or URL) needed by the loader is missing or unreadable (details: file | url, status?). */
export class WorkspaceFileError extends RobwotError {
  override name = "WorkspaceFileError";
  constructor(message: string, details: ErrorDetails = {}, options?: { cause?: unknown }) {
    super("E_FILE_NOT_FOUND", message, details, options);
  }
}
