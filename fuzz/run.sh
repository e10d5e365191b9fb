#!/usr/bin/env bash
# Runs each libFuzzer target of fuzz/ for SECONDS seconds on a scratch corpus
# (BUILD/corpus/TARGET, seeded from the repository's device files, logs,
# malformed inputs and fuzz/seeds; the repository is not modified) and fails if
# any of them finds a crash, a leak, a timeout or an out-of-memory input.
# Usage: fuzz/run.sh BUILD_DIR SECONDS [TARGET...]   (make fuzz calls it)
set -uo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)"
seconds="$2"
shift 2
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_device fuzz_fixture fuzz_log fuzz_log_columns fuzz_scenario fuzz_urdf
  fuzz_ros1_bag fuzz_mcap fuzz_ros_message fuzz_tracker_export)

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
    fuzz_ros1_bag | fuzz_mcap | fuzz_ros_message | fuzz_tracker_export)
      ls "$src"/fuzz/seeds/"${1#fuzz_}"/* ;;
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
  if TMPDIR="$build/tmp" "$build/fuzz/$t" "$corpus" -dict="$src/fuzz/$(dict "$t").dict" \
      -max_len=1048576 -rss_limit_mb=2048 -timeout=10 -max_total_time="$seconds" \
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
