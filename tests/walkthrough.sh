#!/usr/bin/env bash
# The README's walk-throughs, as a reader runs them: every ```sh fenced block of
# README.md, in order, from a scratch copy of the repository root.
#
#   readme_walkthrough.sh SRC BUILD
#
# SRC is the source tree (README.md, data/, examples/), BUILD the build tree
# (hapticcal, realtime_controller, python/). The blocks run in a fresh folder
# (mktemp -d, removed on exit) holding `build` -> BUILD and copies of SRC's data/
# and examples/ (under 1 MB), so that the commands run as written and cannot
# write into the source tree. Each block runs in its own bash with `set -e` and its commands
# printed (-x); a failing block is named by its number and first line, the
# others still run, and the script exits 1 if any failed. Blocks of other
# languages (```text, ```python, indented ones: the quick start's make run and
# make test, installing) are not run.
set -u
if [ $# -ne 2 ]; then
  echo "usage: $0 SRC BUILD" >&2
  exit 2
fi
src=$(cd "$1" && pwd) || exit 2
build=$(cd "$2" && pwd) || exit 2
[ -f "$src/README.md" ] || { echo "no README.md in $src" >&2; exit 2; }

work=$(mktemp -d "${TMPDIR:-/tmp}/readme_walkthrough.XXXXXX") || exit 1
trap 'rm -rf "$work"' EXIT
ln -s "$build" "$work/build"
for folder in data examples; do cp -R "$src/$folder" "$work/$folder" || exit 1; done

# The Python the build's module is for: Debian's, as python/CMakeLists.txt
# prefers it, ahead of another python3 on PATH (pyenv, a virtualenv).
if [ -x /usr/bin/python3 ]; then
  mkdir "$work/.bin" && ln -s /usr/bin/python3 "$work/.bin/python3"
  export PATH="$work/.bin:$PATH"
fi

# Split the README into blocks: block N's script in $work/.blocks/N.sh.
mkdir "$work/.blocks"
awk -v dir="$work/.blocks" '
  /^```sh[[:space:]]*$/ { n++; file = sprintf("%s/%d.sh", dir, n); inside = 1; next }
  inside && /^```[[:space:]]*$/ { inside = 0; close(file); next }
  inside { print > file }
  END { if (inside) { print "README.md: a ```sh block is not closed" > "/dev/stderr"; exit 1 } }
' "$src/README.md" || exit 1
count=$(find "$work/.blocks" -name '*.sh' | wc -l)
if [ "$count" -eq 0 ]; then
  echo "FAIL: README.md has no \`\`\`sh block"
  exit 1
fi

failed=()
now_ms() { date +%s%3N; }
seconds_since() { awk -v a="$1" -v b="$(now_ms)" 'BEGIN { printf "%.1f", (b - a) / 1000 }'; }
start_all=$(now_ms)
for n in $(seq 1 "$count"); do
  script="$work/.blocks/$n.sh"
  first=$(grep -m1 -v '^[[:space:]]*$' "$script")
  echo "=== block $n of $count: $first"
  start=$(now_ms)
  (cd "$work" && bash -e -x "$script" 2>&1)
  status=$?
  seconds=$(seconds_since "$start")
  if [ "$status" -ne 0 ]; then
    echo "=== FAIL: block $n (exit status $status, ${seconds} s): $first"
    failed+=("block $n: $first")
  else
    echo "=== ok: block $n (${seconds} s)"
  fi
done
echo "=== $count blocks in $(seconds_since "$start_all") s, ${#failed[@]} failed"
if [ ${#failed[@]} -ne 0 ]; then
  printf 'FAIL: %s\n' "${failed[@]}"
  exit 1
fi
