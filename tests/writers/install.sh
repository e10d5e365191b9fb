#!/usr/bin/env bash
# usage: install.sh DEST
# The independent writers of the recording tests (package.json's packages, at the
# lockfile's versions) installed into DEST/node_modules with npm ci, once: again
# only when the lockfile changes. Needs node and npm (Debian's) and the npm registry.
# @foxglove/rosmsg2-serialization 3.x declares node >= 20 and runs on Debian
# bookworm's node 18 (it uses nothing newer; npm only warns): its 2.x writes no
# placeholder byte for an empty message, which ROS 2's rosidl and the CDR test do.
set -euo pipefail
src=$(cd "$(dirname "$0")" && pwd)
dest=$1
mkdir -p "$dest"
if [ -d "$dest/node_modules" ] && cmp -s "$src/package-lock.json" "$dest/package-lock.json"; then
  exit 0
fi
cp "$src/package.json" "$src/package-lock.json" "$dest/"
cd "$dest"
npm ci --no-audit --no-fund --loglevel=error --engine-strict=false
