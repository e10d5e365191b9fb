#!/usr/bin/env bash
# Checks .ci/no_skipped_tests.sh on made-up ctest trees: one whose LastTest.log
# holds no skip (passes), and one for each kind of skip it must catch (fails,
# naming the test). ctest runs it as ci_no_skipped_check.
set -euo pipefail
check="$(cd "$(dirname "$0")" && pwd)/no_skipped_tests.sh"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# tree NAME: a build tree whose LastTest.log has two tests, the second one's
# output read from stdin.
tree() {
  mkdir -p "$work/$1/Testing/Temporary"
  {
    printf '%s\n' "Start testing: Dec 01 21:11 UTC" "----" "1/2 Testing: first" \
      "1/2 Test: first" "Output:" "----" "[==========] 3 tests ran." "[  PASSED  ] 3 tests." \
      "<end of output>" "Test Passed." "2/2 Testing: second" "2/2 Test: second" "Output:" "----"
    cat
    printf '%s\n' "<end of output>" "Test Passed." "End testing: Dec 01 21:11 UTC"
  } >"$work/$1/Testing/Temporary/LastTest.log"
}

failures=0
expect() {  # expect pass|fail TEXT TREE...: the check's exit and output
  local want=$1 text=$2 out rc
  shift 2
  rc=0
  out=$("$check" "$@" 2>&1) || rc=$?
  if { [ "$want" = pass ] && [ "$rc" != 0 ]; } || { [ "$want" = fail ] && [ "$rc" = 0 ]; } ||
    ! grep -qF -- "$text" <<<"$out"; then
    echo "FAIL: expected $want with '$text' for $*; exit $rc:"
    echo "$out"
    failures=$((failures + 1))
  fi
}

tree clean <<'EOF'
[ RUN      ] Report.FiguresSkippedWithoutGnuplot
figures skipped: gnuplot not found
[       OK ] Report.FiguresSkippedWithoutGnuplot (5 ms)
  YOU HAVE 1 DISABLED TEST
..                                                                       [100%]
2 passed in 0.31s
EOF
expect pass "2 tests, none skipped" "$work/clean"

tree gtest <<'EOF'
[ RUN      ] Report.EveryReportLoadsInChromium
[  SKIPPED ] Report.EveryReportLoadsInChromium (0 ms)
[  SKIPPED ] 1 test, listed below:
[  SKIPPED ] Report.EveryReportLoadsInChromium
EOF
expect fail "second: [  SKIPPED ] Report.EveryReportLoadsInChromium (0 ms)" "$work/gtest"

tree pytest <<'EOF'
.s                                                                       [100%]
=========================== short test summary info ============================
SKIPPED [1] python/tests/test_hapticcal.py:12: no module
1 passed, 1 skipped in 0.05s
EOF
expect fail "second: SKIPPED [1] python/tests/test_hapticcal.py:12" "$work/pytest"

tree pytest_summary_only <<'EOF'
=================== 4 passed, 2 skipped in 1.20s ===================
EOF
expect fail "2 skipped in 1.20s" "$work/pytest_summary_only"

tree not_run <<'EOF'
EOF
sed -i 's|^2/2 Testing: second|Unable to find executable: /build/tests/statistics_test\n&|' \
  "$work/not_run/Testing/Temporary/LastTest.log"
expect fail "(the next test): Unable to find executable" "$work/not_run"

tree ctest_skipped <<'EOF'
EOF
printf '2:second\n' >"$work/ctest_skipped/Testing/Temporary/LastTestsDisabled.log"
expect fail "second: skipped or disabled by ctest" "$work/ctest_skipped"

# Every tree is checked: a clean one first does not hide a skip after it.
expect fail "[  SKIPPED ]" "$work/clean" "$work/gtest"
expect fail "no $work/missing/Testing/Temporary/LastTest.log" "$work/missing"

if [ "$failures" != 0 ]; then
  echo "$failures checks of no_skipped_tests.sh failed"
  exit 1
fi
echo "no_skipped_tests.sh: a clean tree passes; gtest, pytest and ctest skips fail"
