// Validate one .glb/.gltf with the Khronos glTF-Validator and print a one-line JSON summary:
//   {"errors": N, "warnings": N, "infos": N, "hints": N, "messages": [{code, severity, pointer, message}]}
//
// Usage: node tests/validate_gltf.js FILE
// Exit status: 0 when validated (whatever it found), 2 if the gltf-validator package cannot be found,
// 1 if the file could not be read or validated at all.
// The package is looked up where `npm install --prefix .ci/node gltf-validator` puts it, then on the usual
// module path (NODE_PATH, global installs).
"use strict";
const fs = require("fs");
const path = require("path");

function loadValidator() {
  const local = path.join(__dirname, "..", ".ci", "node", "node_modules");
  for (const attempt of [() => require(require.resolve("gltf-validator", { paths: [local] })),
                         () => require("gltf-validator")]) {
    try {
      return attempt();
    } catch (e) {
      if (e.code !== "MODULE_NOT_FOUND") throw e;
    }
  }
  return null;
}

async function main() {
  const file = process.argv[2];
  if (!file) {
    console.error("usage: node validate_gltf.js FILE");
    return 1;
  }
  const validator = loadValidator();
  if (validator === null) {
    console.error("gltf-validator is not installed (npm install --prefix .ci/node gltf-validator)");
    return 2;
  }
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      fs.promises.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))),
  });
  const issues = report.issues;
  console.log(JSON.stringify({
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    hints: issues.numHints,
    messages: issues.messages.map((m) => ({ code: m.code, severity: m.severity, pointer: m.pointer,
                                            message: m.message })),
  }));
  return 0;
}

main().then((code) => { process.exitCode = code; },
            (error) => { console.error(String(error)); process.exitCode = 1; });
