#!/bin/sh
# The Khronos glTF validator from the npm registry (gltf-validator), for
# test_gltf: installed into DIR (DIR/node_modules/gltf-validator) where
# Node.js and npm are found and it is not there yet. Without them, or
# without the registry, it says so and test_gltf skips the validation.
# usage: need-gltf-validator.sh DIR
set -u
dir=$1
[ -f "$dir/node_modules/gltf-validator/package.json" ] && exit 0
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    echo "note: Node.js/npm not found: glTF outputs are not validated (Debian: nodejs, npm)"
    exit 0
fi
mkdir -p "$dir"
if npm install --prefix "$dir" --no-audit --no-fund --loglevel=error gltf-validator >/dev/null 2>&1; then
    echo "installed the glTF validator (npm gltf-validator) into $dir"
else
    echo "note: npm could not install gltf-validator: glTF outputs are not validated"
fi
exit 0
