// Validate a GLB with the Khronos glTF validator; prints its JSON report.
import fs from "node:fs";
import { createRequire } from "node:module";
const require = createRequire(import.meta.url);
const validator = require(process.argv[3]);
const bytes = new Uint8Array(fs.readFileSync(process.argv[2]));
const report = await validator.validateBytes(bytes);
console.log(JSON.stringify(report));
