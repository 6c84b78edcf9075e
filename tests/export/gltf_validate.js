// Validate a glTF/GLB file with the Khronos glTF validator (npm package gltf-validator) and
// print its JSON report. The package is found through PROCEDURA_GLTF_VALIDATOR (its folder,
// e.g. /work/npm/node_modules/gltf-validator) or node's own resolution (NODE_PATH, global).
// Usage: node gltf_validate.js FILE.glb
const fs = require("fs");
const validator = require(process.env.PROCEDURA_GLTF_VALIDATOR || "gltf-validator");
const data = fs.readFileSync(process.argv[2]);
validator.validateBytes(new Uint8Array(data))
  .then((report) => { process.stdout.write(JSON.stringify(report)); })
  .catch((err) => { process.stderr.write(String(err) + "\n"); process.exit(2); });
