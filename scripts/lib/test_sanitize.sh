#!/usr/bin/env bash
# scripts/test --sanitize: every gtest (no master) built with AddressSanitizer and
# UndefinedBehaviorSanitizer in the workspace .ws/asan, then the transport's tests (the Bridge's
# threads and sockets) with ThreadSanitizer in .ws/tsan. Any sanitizer report stops its test
# binary and counts as a failure. Ends with "N passed, N failed, N skipped" like scripts/test.
set -euo pipefail
source "$(dirname "$0")/env.sh"

main_ws=$CCIR_WS
results="$main_ws/sanitize_results"
rm -rf "$results"
mkdir -p "$results"
export LSAN_OPTIONS="suppressions=$CCIR_ROOT/test/fuzz/lsan.supp"
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:strict_string_checks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1"

# Builds one sanitizer's workspace (scripts/setup with its flags; ccache keeps them apart).
build() {
  local name=$1 flags=$2 targets=$3 start
  start=$(date +%s)
  # Leaks of the tools that write fixtures do not matter.
  ASAN_OPTIONS=detect_leaks=0 CCIR_WS="$main_ws/$name" CCIR_BUILD_TYPE=RelWithDebInfo CCIR_TARGETS="$targets" \
    CCIR_CXX_FLAGS="$flags -fno-omit-frame-pointer" CCIR_LOG_DIR="$main_ws/$name/logs" \
    "$CCIR_ROOT/scripts/setup" >"$CCIR_LOG_DIR/sanitize_$name.log" 2>&1 || {
    tail -20 "$CCIR_LOG_DIR/sanitize_$name.log"
    echo "[sanitize] the $name build failed (log: $CCIR_LOG_DIR/sanitize_$name.log)"
    echo "0 passed, 1 failed"
    exit 1
  }
  echo "[sanitize] $name build: $(($(date +%s) - start)) s"
}

# Runs gtest binaries; one that exits non-zero (a sanitizer report, a crash) adds a failed case
# with the end of its log, since it may have left no result file.
run() {
  local name=$1 binary test status start
  shift
  start=$(date +%s)
  set +u
  # shellcheck disable=SC1091
  source "$main_ws/$name/devel/setup.bash"  # ros_tests find the package through rospack
  set -u
  for binary in "$@"; do
    test=$(basename "$binary")
    status=0
    "$binary" --gtest_output="xml:$results/$name-$test.xml" >"$CCIR_LOG_DIR/sanitize_$name-$test.log" 2>&1 ||
      status=$?
    if ((status)); then
      local report
      report=$(grep -m1 -E "ERROR: (Address|Leak|Thread)Sanitizer|runtime error:|WARNING: ThreadSanitizer" \
        "$CCIR_LOG_DIR/sanitize_$name-$test.log" || tail -1 "$CCIR_LOG_DIR/sanitize_$name-$test.log")
      report=${report//&/and}
      printf '<testsuite name="%s" tests="1"><testcase classname="%s" name="exit"><failure message="exit code %d: %s (log: %s)"/></testcase></testsuite>\n' \
        "$test" "$name" "$status" "${report//\"/\'}" "$CCIR_LOG_DIR/sanitize_$name-$test.log" \
        >"$results/$name-$test-exit.xml"
    fi
  done
  echo "[sanitize] $name tests ran in $(($(date +%s) - start)) s"
}

# Eigen assumes malloc is not 16-byte aligned under ASan and pads its own allocations, while the
# system's PCL and Ceres (built without ASan) do not: memory one side allocates and the other
# frees would be reported. Both sides must agree, as glibc's malloc does align.
build asan "-fsanitize=address,undefined -fno-sanitize-recover=undefined -DEIGEN_MALLOC_ALREADY_ALIGNED=1" tests
run asan "$main_ws"/asan/devel/lib/ccir_mapping/ccir_mapping_*_tests
build tsan "-fsanitize=thread" ccir_mapping_transport_tests
run tsan "$main_ws"/tsan/devel/lib/ccir_mapping/ccir_mapping_transport_tests

/usr/bin/python3 -m ccir_mapping.summarize_results "$results"  # the package of the last workspace
