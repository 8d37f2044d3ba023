// Validates each glTF/GLB file named on the command line with the Khronos glTF validator and
// prints one JSON line per file: {"file", "errors", "warnings", "infos", "hints", "messages"}.
// Exits 1 when any file has an error (or cannot be read), 0 otherwise. External resources of a
// .gltf are read relative to the file.
import { readFile } from "node:fs/promises";
import path from "node:path";
import validator from "gltf-validator";

let failed = false;
for (const file of process.argv.slice(2)) {
  try {
    const bytes = new Uint8Array(await readFile(file));
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 50,
      externalResourceFunction: (uri) =>
        readFile(path.join(path.dirname(file), decodeURIComponent(uri))).then(
          (b) => new Uint8Array(b),
        ),
    });
    const issues = report.issues;
    const messages = issues.messages
      .filter((m) => m.severity <= 1)
      .map((m) => `${m.severity === 0 ? "error" : "warning"} ${m.code} at ${m.pointer}: ${m.message}`);
    console.log(
      JSON.stringify({
        file,
        errors: issues.numErrors,
        warnings: issues.numWarnings,
        infos: issues.numInfos,
        hints: issues.numHints,
        messages,
      }),
    );
    if (issues.numErrors > 0) failed = true;
  } catch (e) {
    console.log(JSON.stringify({ file, errors: 1, messages: [`could not validate: ${e}`] }));
    failed = true;
  }
}
process.exit(failed ? 1 : 0);
