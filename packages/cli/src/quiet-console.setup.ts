/** Vitest setup: the tests' console without ajv's format noise, as the CLI's (quiet-console.ts). */
import { silenceAjvFormatNoise } from "./quiet-console.js";

silenceAjvFormatNoise();
