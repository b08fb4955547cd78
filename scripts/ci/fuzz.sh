#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, with AddressSanitizer and
# UndefinedBehaviorSanitizer) into build_fuzz/ and runs each for SECONDS
# (default 30) from its corpus under test/fuzz/corpus/NAME, after running
# every kept crash input under test/fuzz/regressions/NAME once. New inputs go
# to build_fuzz/corpus/NAME; a crash fails the script and leaves its input in
# build_fuzz/crash-NAME-*: fix it, then keep it under test/fuzz/regressions/NAME.
# usage: fuzz.sh [SECONDS] [NAME...]
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
secs="${1:-30}"; shift || true
names=("$@"); [ ${#names[@]} -gt 0 ] || names=(fuzz_scip fuzz_dynamixel fuzz_split fuzz_grouping)
build="${TLP_FUZZ_BUILD:-$here/build_fuzz}"
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -fsanitize=fuzzer-no-link"
cmake -S "$here/ros_free" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTLP_TESTS=OFF -DTLP_FUZZ=ON \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
cmake --build "$build" --target "${names[@]}" -- -j2
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
status=0
for n in "${names[@]}"; do
  reg="$here/test/fuzz/regressions/$n"
  if [ -d "$reg" ] && [ -n "$(ls -A "$reg")" ]; then
    echo "== $n: kept crash inputs"
    "$build/$n" "$reg"/* 2>&1 | tail -2 || status=1
  fi
  mkdir -p "$build/corpus/$n"
  echo "== $n: ${secs} s"
  if ! "$build/$n" -max_total_time="$secs" -print_final_stats=1 -artifact_prefix="$build/crash-$n-" \
      -max_len=8192 "$build/corpus/$n" "$here/test/fuzz/corpus/$n" >"$build/$n.log" 2>&1; then
    status=1
    echo "   CRASH: see $build/$n.log"; tail -40 "$build/$n.log"
  fi
  grep -E "stat::number_of_executed_units|stat::new_units_added" "$build/$n.log" | tr '\n' ' '; echo
  grep -o "cov: [0-9]*" "$build/$n.log" | tail -1 || true
done
exit $status
