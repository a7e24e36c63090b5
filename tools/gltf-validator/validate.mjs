// Runs the Khronos glTF-Validator (npm package `gltf-validator`) on each file named on
// the command line (.glb or .gltf) and prints every issue it reports.
//
//   npm ci --prefix tools/gltf-validator
//   node tools/gltf-validator/validate.mjs [--no-infos] out.glb out.gltf
//
// Exit status: 0 when every file has no errors and no warnings (infos and hints are
// fine; with --no-infos an info fails too: an unused attribute or object, an
// unsupported extension), 1 when any file has an error or a warning or could not be
// read or parsed, 2 on bad usage. Used by the Rust tests through crates/sylva/tests/common/gltf_validator.rs.

import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

const SEVERITY = ["error", "warning", "info", "hint"];

const noInfos = process.argv.includes("--no-infos");
const files = process.argv.slice(2).filter((a) => a !== "--no-infos");
if (files.length === 0) {
  console.error("usage: node validate.mjs FILE.glb|FILE.gltf ...");
  process.exit(2);
}

let failed = false;
for (const file of files) {
  let report;
  try {
    const bytes = await readFile(file);
    report = await validator.validateBytes(new Uint8Array(bytes), {
      uri: path.basename(file),
      maxIssues: 0,
      writeTimestamp: false,
      // Resolve external buffers relative to the file (sylva embeds its buffer, but
      // a file written by something else may not).
      externalResourceFunction: (uri) =>
        readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then(
          (data) => new Uint8Array(data),
        ),
    });
  } catch (error) {
    console.log(`${file}: FAILED to validate: ${error}`);
    failed = true;
    continue;
  }
  const issues = report.issues;
  const bad = issues.numErrors + issues.numWarnings + (noInfos ? issues.numInfos : 0);
  console.log(
    `${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
      `${issues.numInfos} infos, ${issues.numHints} hints` +
      (report.info && report.info.generator ? ` (generator: ${report.info.generator})` : ""),
  );
  for (const m of issues.messages) {
    const where = m.pointer ?? (m.offset !== undefined ? `byte ${m.offset}` : "");
    console.log(`  ${SEVERITY[m.severity] ?? m.severity} ${m.code}: ${m.message} ${where}`.trimEnd());
  }
  if (bad > 0) failed = true;
}
process.exit(failed ? 1 : 0);
