#!/bin/sh
# Installs the Khronos glTF validator (npm package gltf-validator) under PREFIX for the validation
# tests: sh setup.sh PREFIX. Writes PREFIX/.tm_gltf_validator_ready when the validator is usable.
# Exit status 77 (ctest SKIP_RETURN_CODE) when npm is missing or cannot reach its registry.
set -u
prefix="$1"
marker="$prefix/.tm_gltf_validator_ready"
rm -f "$marker"
if ! command -v npm >/dev/null 2>&1 || ! command -v node >/dev/null 2>&1; then
  echo "SKIPPED: npm or node is not installed; the glTF validator tests are skipped"
  exit 77
fi
mkdir -p "$prefix" || exit 1
log="$prefix/npm-install.log"
usable() { node -e "require('$prefix/node_modules/gltf-validator')" >/dev/null 2>&1; }
if npm install --no-audit --no-fund --prefix "$prefix" gltf-validator >"$log" 2>&1 && usable; then
  cat "$log"
  touch "$marker"
  exit 0
fi
cat "$log"
if grep -Eqi "ENOTFOUND|EAI_AGAIN|ECONNREFUSED|ECONNRESET|ETIMEDOUT|ENETUNREACH|EHOSTUNREACH|ERR_SOCKET|E50[234]|network|proxy" "$log"; then
  if usable; then
    echo "npm could not reach its registry; using the gltf-validator already installed in $prefix"
    touch "$marker"
    exit 0
  fi
  echo "SKIPPED: npm could not reach its registry; the glTF validator tests are skipped"
  exit 77
fi
echo "npm install gltf-validator failed (see the log above)"
exit 1
