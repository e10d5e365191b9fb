#!/usr/bin/env bash
# usage: install.sh DEST
# The independent writers of the recording tests (package.json's packages, at the
# lockfile's versions) installed into DEST/node_modules with npm ci, once: again
# only when the lockfile changes. Needs node and npm (Debian's) and the npm registry.
set -euo pipefail
src=$(cd "$(dirname "$0")" && pwd)
dest=$1
mkdir -p "$dest"
if [ -d "$dest/node_modules" ] && cmp -s "$src/package-lock.json" "$dest/package-lock.json"; then
  exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dest/"
cd "$dest"
npm ci --no-audit --no-fund --loglevel=error
