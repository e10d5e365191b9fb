#!/usr/bin/env bash
# The pages of docs/ against the repository and the current build:
#
#   docs_check.sh SRC BUILD
#
# 1. Every file or folder of the repository a page names (in backquotes or as a
#    link: data/..., examples/..., tests/..., src/..., docs/..., a sibling
#    page) exists in SRC, and no page cites a file the repository does not
#    ship (the product specification the project started from).
# 2. Every page with ```sh blocks is walked through (tests/walkthrough.sh): its
#    blocks run as a reader runs them, and a ```text block quoted right after
#    one must be what it printed, so the page's figures are the current build's.
# Exits 1 naming each missing file and each failed block.
set -u
if [ $# -ne 2 ]; then
  echo "usage: $0 SRC BUILD" >&2
  exit 2
fi
src=$(cd "$1" && pwd) || exit 2
build=$(cd "$2" && pwd) || exit 2
here=$(cd "$(dirname "$0")" && pwd)
failed=0
missing=$(mktemp) || exit 1
trap 'rm -f "$missing"' EXIT

# 1. Names of the repository's files. A name with a placeholder (DIR, FILE,
# NAME, *, <...>, {...}) or a folder the user makes (out/, build/) is not one.
roots='(data|examples|tests|src|include|bench|tools|python|docs|fuzz|apps|cmake)'
for page in "$src"/README.md "$src"/docs/*.md; do
  rel=${page#"$src"/}
  dir=$(dirname "$page")
  # Backquoted repository paths, and link targets (relative to the page).
  { grep -oE "\`$roots/[A-Za-z0-9_.@/+-]+\`" "$page" | tr -d '`' | sed "s|^|$src/|"
    grep -oE '\]\([^)#[:space:]]+' "$page" | sed 's/^](//' | grep -vE '^(https?|mailto):' |
      sed "s|^|$dir/|"
  } | grep -vE '(\*|<|>|\{|\}|\.\.\.|DIR|FILE|NAME|PATH)' | sort -u |
    while IFS= read -r path; do
      path=${path%/}
      path=${path%.}
      path=${path%,}
      if [ ! -e "$path" ] && [ ! -e "$path.cpp" ]; then  # a file, or a program's source
        echo "FAIL: $rel names ${path#"$src"/}, which the repository does not have"
        echo "$path" >> "$missing"
      fi
    done
  if grep -nE '\bSPEC(\.md)?\b' "$page"; then
    echo "FAIL: $rel cites the SPEC, which the repository does not ship"
    failed=1
  fi
done
[ -s "$missing" ] && failed=1

# 2. The pages' walk-throughs.
for page in "$src"/docs/*.md; do
  grep -q '^```sh[[:space:]]*$' "$page" || continue
  bash "$here/walkthrough.sh" "$src" "$build" "docs/$(basename "$page")" || failed=1
done
exit $failed
