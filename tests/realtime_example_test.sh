#!/bin/sh
# examples/realtime for 0.3 s: exit status 0 and every timing statistic printed.
out=$("$1" --seconds 0.3) || { echo "$out"; echo "FAIL: exit status $?"; exit 1; }
echo "$out"
for pattern in 'period \[us\]: mean .* median .* p99 .* max .* max jitter' \
  'compute \[us\]: median .* max' 'missed deadlines: [0-9]* of 300' 'peak force [0-9.]* N'; do
  echo "$out" | grep -q "$pattern" || { echo "FAIL: no line matching: $pattern"; exit 1; }
done
