#!/usr/bin/env bash
# Writes Foxglove's JSON Schemas of the messages `pgm ... --mcap` records into
# src/foxglove/schemas/, unchanged, from Foxglove's npm package @foxglove/schemas
# (MIT; generated from https://github.com/foxglove/foxglove-sdk). Needs node and npm
# and the npm registry. Run from the repository's root; commit the result.
set -euo pipefail
version="${1:-2.1.0}"
out="$(pwd)/src/foxglove/schemas"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$work"
npm pack --silent "@foxglove/schemas@$version" >/dev/null
tar xzf foxglove-schemas-"$version".tgz
npm install --silent --no-save --prefix package tslib >/dev/null
mkdir -p "$out"
node -e '
const s = require("./package/dist/jsonschema");
const fs = require("fs");
for (const name of ["LaserScan", "FrameTransform", "SceneUpdate"]) {
  fs.writeFileSync(process.argv[1] + "/" + name + ".json", JSON.stringify(s[name], null, 2) + "\n");
}' "$out"
echo "@foxglove/schemas $version" > "$out/VERSION"
echo "wrote $(ls "$out" | wc -l) files into $out"
