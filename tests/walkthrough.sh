#!/usr/bin/env bash
# A page's walk-throughs, as a reader runs them: every ```sh fenced block of the
# page (README.md, or a page of docs/), in order, from a scratch copy of the
# repository root.
#
#   walkthrough.sh SRC BUILD [PAGE]
#
# SRC is the source tree (README.md, docs/, data/, examples/), BUILD the build
# tree (hapticcal, realtime_controller, python/), PAGE a Markdown file of SRC
# (README.md by default). The blocks run in a fresh folder (mktemp -d, removed
# on exit) holding `build` -> BUILD and copies of SRC's data/ and examples/
# (under 1 MB), so that the commands run as written and cannot write into the
# source tree. Each block runs in its own bash with `set -e` and its commands
# printed (-x); a failing block is named by its number and first line, the
# others still run, and the script exits 1 if any failed.
#
# A ```text block right after a ```sh block (blank lines between) is the
# block's output as the page quotes it: each of its non-blank lines must be a
# line of what the block printed (blanks runs compared as one), so a page's
# figures are the current build's. Blocks of other languages (```text on its
# own, ```python, indented ones: the quick start's make run and make test,
# installing) are not run.
set -u
if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: $0 SRC BUILD [PAGE]" >&2
  exit 2
fi
src=$(cd "$1" && pwd) || exit 2
build=$(cd "$2" && pwd) || exit 2
page=${3:-README.md}
[ -f "$src/$page" ] || { echo "no $page in $src" >&2; exit 2; }

work=$(mktemp -d "${TMPDIR:-/tmp}/walkthrough.XXXXXX") || exit 1
trap 'rm -rf "$work"' EXIT
ln -s "$build" "$work/build"
for folder in data examples; do cp -R "$src/$folder" "$work/$folder" || exit 1; done

# The Python the build's module is for: Debian's, as python/CMakeLists.txt
# prefers it, ahead of another python3 on PATH (pyenv, a virtualenv); and the
# build's program under its installed name (the pages of docs/ write
# `hapticcal`, the README `build/hapticcal`).
mkdir "$work/.bin" && ln -s "$build/hapticcal" "$work/.bin/hapticcal" || exit 1
[ -x /usr/bin/python3 ] && ln -s /usr/bin/python3 "$work/.bin/python3"
export PATH="$work/.bin:$PATH"

# Split the page into blocks: block N's script in $work/.blocks/N.sh, and the
# output the page quotes for it, if any, in N.expected.
mkdir "$work/.blocks"
awk -v dir="$work/.blocks" -v page="$page" '
  /^```sh[[:space:]]*$/ { n++; file = sprintf("%s/%d.sh", dir, n); inside = 1; after = 0; next }
  inside && /^```[[:space:]]*$/ { inside = 0; close(file); after = 1; next }
  inside { print > file; next }
  after && /^```text[[:space:]]*$/ { quoted = 1; after = 0; file = sprintf("%s/%d.expected", dir, n); next }
  quoted && /^```[[:space:]]*$/ { quoted = 0; close(file); next }
  quoted { print > file; next }
  after && !/^[[:space:]]*$/ { after = 0 }
  END { if (inside || quoted) { print page ": a fenced block is not closed" > "/dev/stderr"; exit 1 } }
' "$src/$page" || exit 1
count=$(find "$work/.blocks" -name '*.sh' | wc -l)
if [ "$count" -eq 0 ]; then
  echo "FAIL: $page has no \`\`\`sh block"
  exit 1
fi

# Blanks squeezed, ends trimmed: a quoted line compared with a printed one.
squeeze() { sed -e 's/[[:space:]]\+/ /g' -e 's/^ //' -e 's/ $//'; }

failed=()
now_ms() { date +%s%3N; }
seconds_since() { awk -v a="$1" -v b="$(now_ms)" 'BEGIN { printf "%.1f", (b - a) / 1000 }'; }
start_all=$(now_ms)
for n in $(seq 1 "$count"); do
  script="$work/.blocks/$n.sh"
  first=$(grep -m1 -v '^[[:space:]]*$' "$script")
  echo "=== block $n of $count: $first"
  start=$(now_ms)
  (cd "$work" && bash -e -x "$script" 2>&1) | tee "$work/.blocks/$n.out"
  status=${PIPESTATUS[0]}
  seconds=$(seconds_since "$start")
  missing=""
  if [ "$status" -eq 0 ] && [ -f "$work/.blocks/$n.expected" ]; then
    squeeze < "$work/.blocks/$n.out" > "$work/.blocks/$n.printed"
    while IFS= read -r line; do
      wanted=$(printf '%s\n' "$line" | squeeze)
      [ -z "$wanted" ] && continue
      grep -qxF -- "$wanted" "$work/.blocks/$n.printed" || missing+="    $wanted"$'\n'
    done < "$work/.blocks/$n.expected"
  fi
  if [ -n "$missing" ]; then
    echo "=== FAIL: block $n: $page quotes lines it did not print:"
    printf '%s' "$missing"
    failed+=("block $n: $first (the quoted output differs)")
  elif [ "$status" -ne 0 ]; then
    echo "=== FAIL: block $n (exit status $status, ${seconds} s): $first"
    failed+=("block $n: $first")
  else
    echo "=== ok: block $n (${seconds} s)"
  fi
done
echo "=== $page: $count blocks in $(seconds_since "$start_all") s, ${#failed[@]} failed"
if [ ${#failed[@]} -ne 0 ]; then
  printf 'FAIL: %s\n' "${failed[@]}"
  exit 1
fi
