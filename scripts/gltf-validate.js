#!/usr/bin/env node
// The Khronos glTF validator (npm gltf-validator) on each file named:
// prints "FILE: E errors, W warnings" (and each error), exits 1 when a file
// has an error. The validator's module is found through NODE_PATH or the
// MR_GLTF_VALIDATOR folder (node_modules of an `npm install gltf-validator`).
'use strict';
const fs = require('fs');
const path = require('path');

function load() {
  const dir = process.env.MR_GLTF_VALIDATOR;
  try {
    return require(dir ? path.join(dir, 'gltf-validator') : 'gltf-validator');
  } catch (e) {
    console.error('gltf-validator not found (npm install gltf-validator; ' +
                  'MR_GLTF_VALIDATOR=its node_modules folder)');
    process.exit(77);
  }
}

async function main() {
  const validator = load();
  let failed = false;
  for (const file of process.argv.slice(2)) {
    const full = path.resolve(file);
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(full)), {
      uri: path.basename(full),
      maxIssues: 100,
      externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(full), decodeURIComponent(uri)),
                    (err, data) => err ? reject(err.toString()) : resolve(data));
      }),
    });
    const is = report.issues;
    console.log(`${file}: ${is.numErrors} errors, ${is.numWarnings} warnings`);
    for (const m of is.messages)
      if (m.severity === 0 || process.env.MR_GLTF_VERBOSE)
        console.log(`  ${m.severity === 0 ? 'error' : 'note'} ${m.code} ${m.pointer || ''}: ${m.message}`);
    if (is.numErrors > 0)
      failed = true;
  }
  process.exit(failed ? 1 : 0);
}

main().catch((e) => { console.error(String(e)); process.exit(2); });
