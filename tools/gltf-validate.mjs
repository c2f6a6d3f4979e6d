#!/usr/bin/env node
// Validates one glTF 2.0 file (.glb, or .gltf with its external files beside it)
// with the Khronos glTF-Validator and prints its JSON report on stdout.
// Exit status: 0 no errors, 1 errors in the file, 2 bad usage or unreadable file.
//   node tools/gltf-validate.mjs FILE
// Installed by scripts/install-gltf-validator.sh (tools/node_modules).
import { readFile } from 'node:fs/promises';
import { createRequire } from 'node:module';
import path from 'node:path';

const require = createRequire(import.meta.url);
const file = process.argv[2];
if (!file || process.argv.length > 3) {
    console.error('usage: node tools/gltf-validate.mjs FILE.glb|FILE.gltf');
    process.exit(2);
}
let validator;
try {
    validator = require('gltf-validator');
} catch (e) {
    console.error(`gltf-validate: gltf-validator is not installed (scripts/install-gltf-validator.sh): ${e.message}`);
    process.exit(2);
}
let bytes;
try {
    bytes = new Uint8Array(await readFile(file));
} catch (e) {
    console.error(`gltf-validate: ${file}: ${e.message}`);
    process.exit(2);
}
const dir = path.dirname(file);
let report;
try {
    report = await validator.validateBytes(bytes, {
        uri: path.basename(file),
        maxIssues: 0, // report every issue
        writeTimestamp: false,
        externalResourceFunction: (uri) =>
            readFile(path.resolve(dir, decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
    });
} catch (e) {
    // Not glTF at all (no magic, no JSON): the validator throws instead of reporting.
    console.error(`gltf-validate: ${file}: ${e.message ?? e}`);
    process.exit(1);
}
console.log(JSON.stringify(report, null, 2));
process.exit(report.issues.numErrors > 0 ? 1 : 0);
