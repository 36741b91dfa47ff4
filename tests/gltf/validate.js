// Validates glTF files with the Khronos glTF validator: node validate.js FILE...
// Prints, per file, the number of errors, warnings, infos and hints and every error and warning.
// Exit status: 0 when no file has errors, 1 when one has, 77 when the validator is not installed
// (install it with: npm install --prefix DIR gltf-validator, then run with NODE_PATH=DIR/node_modules).
'use strict';
const fs = require('fs');
const path = require('path');

let validator;
try {
  validator = require('gltf-validator');
} catch (e) {
  console.log('SKIPPED: the gltf-validator package is not installed (' + e.message.split('\n')[0] + ')');
  process.exit(77);
}

async function validate(file) {
  const externalResourceFunction = (uri) =>
    new Promise((resolve, reject) => {
      fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
        err ? reject(err.toString()) : resolve(new Uint8Array(data)));
    });
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    externalResourceFunction,
    maxIssues: 0,
  });
  const issues = report.issues;
  console.log(`${file}: errors: ${issues.numErrors}, warnings: ${issues.numWarnings}, ` +
              `infos: ${issues.numInfos}, hints: ${issues.numHints}`);
  for (const m of issues.messages) {
    if (m.severity > 1) continue;  // 0 error, 1 warning, 2 info, 3 hint
    console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} at ${m.pointer || '-'}: ${m.message}`);
  }
  return issues.numErrors;
}

(async () => {
  const files = process.argv.slice(2);
  if (files.length === 0) {
    console.error('usage: node validate.js FILE.glb|FILE.gltf...');
    process.exit(2);
  }
  let errors = 0;
  for (const f of files) {
    try {
      errors += await validate(f);
    } catch (e) {
      console.log(`${f}: cannot validate: ${e}`);
      errors += 1;
    }
  }
  process.exit(errors > 0 ? 1 : 0);
})();
