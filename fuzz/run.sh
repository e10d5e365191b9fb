#!/usr/bin/env bash
# Runs each libFuzzer target of fuzz/ for SECONDS seconds on a scratch corpus
# (BUILD/corpus/TARGET, seeded from the repository's device files, logs,
# malformed inputs and fuzz/seeds; the repository is not modified) and fails if
# any of them finds a crash, a leak, a timeout or an out-of-memory input (each
# target's bounds: bounds() below).
# Usage: fuzz/run.sh BUILD_DIR SECONDS [TARGET...]   (make fuzz calls it)
set -uo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)"
seconds="$2"
shift 2
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_device fuzz_fixture fuzz_log fuzz_log_columns fuzz_scenario fuzz_urdf
  fuzz_ros1_bag fuzz_mcap fuzz_ros_message fuzz_db3 fuzz_import fuzz_tracker_export)

seeds() {
  case "$1" in
    fuzz_device)
      ls "$src"/data/devices/*.yaml "$src"/tests/malformed/*.yaml
      find "$src/examples" -name '*.yaml' ;;
    fuzz_fixture)
      ls "$src"/tests/malformed/fixture-*.yaml "$src"/fuzz/seeds/fixture/* ;;
    fuzz_log)
      ls "$src"/tests/malformed/*.csv
      find "$src/examples" -name '*.csv' ;;
    fuzz_log_columns)  # the first line is the --columns list: a CSV's header is one
      ls "$src"/tests/malformed/*.csv "$src"/fuzz/seeds/log_columns/*
      find "$src/examples" -name '*.csv' ;;
    fuzz_scenario)
      ls "$src"/fuzz/seeds/scenario/* ;;
    fuzz_urdf)
      ls "$src"/tests/data/urdf/*.urdf "$src"/fuzz/seeds/urdf/*.urdf ;;
    fuzz_ros1_bag | fuzz_mcap | fuzz_ros_message | fuzz_db3 | fuzz_tracker_export)
      ls "$src"/fuzz/seeds/"${1#fuzz_}"/* ;;
    fuzz_import)  # any recording
      ls "$src"/fuzz/seeds/ros1_bag/* "$src"/fuzz/seeds/mcap/*.mcap "$src"/fuzz/seeds/db3/* \
        "$src"/fuzz/seeds/import/* ;;
  esac
}
# Each input's bounds: its largest size, the time it may take (-timeout, s) and
# the memory (-rss_limit_mb). The recording targets take inputs up to 4 MiB, so
# that what was quadratic is within reach (a JointState of 64,000 joints is
# 1.2 MB, a definition of 100,000 fields 1.3 MB), and 5 s an input: their
# readers are linear (a 4 MiB input takes well under a second, sanitizers on).
bounds() {
  case "$1" in
    fuzz_ros1_bag | fuzz_mcap | fuzz_ros_message | fuzz_db3 | fuzz_import)
      echo "-max_len=4194304 -timeout=5 -rss_limit_mb=1024" ;;
    *)
      echo "-max_len=1048576 -timeout=10 -rss_limit_mb=2048" ;;
  esac
}
dict() {
  case "$1" in
    fuzz_device) echo device ;;
    fuzz_fixture) echo fixture ;;
    fuzz_log | fuzz_log_columns) echo log ;;
    fuzz_scenario) echo scenario ;;
    fuzz_urdf) echo urdf ;;
    *) echo "${1#fuzz_}" ;;
  esac
}

failed=()
for t in "${targets[@]}"; do
  corpus="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  mkdir -p "$corpus" "$artifacts" "$build/tmp"
  seeds "$t" | while read -r f; do cp "$f" "$corpus/seed-$(basename "$f")"; done
  echo "== $t: ${seconds}s, corpus $(ls "$corpus" | wc -l) inputs"
  # TMPDIR: fuzz_scenario's scratch directory stays in the build tree.
  # shellcheck disable=SC2046 # the bounds are several words
  if TMPDIR="$build/tmp" "$build/fuzz/$t" "$corpus" -dict="$src/fuzz/$(dict "$t").dict" \
      $(bounds "$t") -max_total_time="$seconds" \
      -print_final_stats=1 -artifact_prefix="$artifacts/" >"$build/$t.log" 2>&1; then
    grep -E '^stat::number_of_executed_units|^Done' "$build/$t.log" || true
    echo "== $t: no crash; corpus now $(ls "$corpus" | wc -l) inputs"
  else
    tail -n 60 "$build/$t.log"
    echo "== $t: FAILED, input in $artifacts (log $build/$t.log)"
    failed+=("$t")
  fi
done
echo "fuzz: ${#targets[@]} targets, ${seconds}s each; findings in: ${failed[*]:-none}"
echo "fuzz: $((${#targets[@]} - ${#failed[@]})) passed, ${#failed[@]} failed"
[ ${#failed[@]} -eq 0 ]
