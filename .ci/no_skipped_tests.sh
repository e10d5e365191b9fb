#!/usr/bin/env bash
# Fails if a test of the given ctest build trees was skipped or did not run.
#   .ci/no_skipped_tests.sh BUILD_DIR...      (.ci/run: build build-asan)
# Reads what ctest keeps of its last run in BUILD_DIR/Testing/Temporary/:
# - LastTest.log, every test's full output, for
#   GoogleTest's "[  SKIPPED ] Suite.Name" (GTEST_SKIP),
#   pytest's "SKIPPED [n] file:line: reason" (python_test runs pytest with -rs)
#   and its "n skipped" summary,
#   and the reasons ctest writes there for a test it did not run ("Unable to find
#   executable", "Unable to find required file", "Failed test dependencies");
# - LastTestsDisabled.log, the tests ctest skipped (SKIP_RETURN_CODE,
#   SKIP_REGULAR_EXPRESSION) or did not run because DISABLED: ctest writes them
#   only there and in its console summary, LastTest.log says "Test Passed." for
#   them. The file is left from an earlier run when the last one skipped nothing:
#   on a tree where ctest ran more than once, an old skip is reported too (CI
#   runs ctest once in each tree of a fresh clone).
# GoogleTest's DISABLED_ tests are not counted: they are never run on purpose,
# each with a comment saying why (tests/plan_test.cpp has one).
# Prints each skip with its log, line and test, and the test count of each tree.
set -euo pipefail

# Tests that may skip: those that need hardware which CI does not have, one
# extended regular expression a test, matched against the line reported (e.g.
# 'SKIPPED \] Device\.TalksToTheRealArm'). None today: no test needs hardware,
# and gnuplot and chromium, which some tests skip without, are installed in CI
# (the Makefile's deps and .ci/run).
allowed=()

if [ $# -eq 0 ]; then
  echo "usage: $0 BUILD_DIR..." >&2
  exit 2
fi

failed=0
for dir in "$@"; do
  tmp="$dir/Testing/Temporary"
  log="$tmp/LastTest.log"
  if [ ! -f "$log" ]; then
    echo "no-skip check: no $log (did ctest run in $dir?)"
    failed=1
    continue
  fi
  # "<log>:<line>: <test>: <text>" for each skip; <test> is the ctest test whose
  # output holds the line (ctest writes "Unable to find executable" before the
  # test's block: the test named there is the next one).
  hits=$(awk -v file="$log" '
    /^[0-9]+\/[0-9]+ Test: / { test = $3; next }
    /^\[  SKIPPED \] [0-9]+ tests?, listed below:/ { next }
    /^\[  SKIPPED \] / ||
    /^SKIPPED \[[0-9]+\] / ||
    /(^|[ =])[0-9]+ skipped(,| in )/ ||
    /^Unable to find (executable|required file)/ ||
    /^Failed test dependencies/ {
      name = test
      if ($0 ~ /^(Unable to find|Failed test dependencies)/) name = "(the next test)"
      printf "%s:%d: %s: %s\n", file, NR, name, $0
    }' "$log")
  if [ -s "$tmp/LastTestsDisabled.log" ]; then
    while IFS= read -r line; do
      hits+="${hits:+$'\n'}$tmp/LastTestsDisabled.log: ${line#*:}: skipped or disabled by ctest"
    done <"$tmp/LastTestsDisabled.log"
  fi
  kept=""
  while IFS= read -r hit; do
    [ -n "$hit" ] || continue
    excused=0
    for pattern in ${allowed[@]+"${allowed[@]}"}; do
      if [[ "$hit" =~ $pattern ]]; then excused=1; fi
    done
    if [ "$excused" = 1 ]; then
      echo "no-skip check: allowed (needs hardware): $hit"
    else
      kept+="$hit"$'\n'
    fi
  done <<<"$hits"
  tests=$(grep -cE '^[0-9]+/[0-9]+ Test: ' "$log" || true)
  if [ -n "$kept" ]; then
    echo "no-skip check: $dir: skipped tests (of $tests run):"
    printf '%s' "$kept"
    failed=1
  else
    echo "no-skip check: $dir: $tests tests, none skipped"
  fi
done

if [ "$failed" != 0 ]; then
  echo "no-skip check FAILED: a test skipped or did not run (install what it needs, or" \
    "list it in .ci/no_skipped_tests.sh's allow-list if it needs hardware)"
  exit 1
fi
