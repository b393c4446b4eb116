#!/usr/bin/env bash
# Fuzz ecmor's input readers with libFuzzer under AddressSanitizer + UndefinedBehaviorSanitizer.
# Usage: scripts/fuzz.sh [seconds] [target]
#   seconds  per target (default 60)
#   target   matrix_market | config | all (default all)
# Builds fuzz/ (its own CMake project, clang++, only the core sources the readers need) into
# build-fuzz/, then runs each target for `seconds` on a working copy of its committed seed corpus
# (build-fuzz/work/<target>/corpus; fuzz/corpus/ is never written). See docs/fuzzing.md.
# Environment: FUZZ_BUILD_DIR (default build-fuzz), FUZZ_JOBS (build jobs, default 2),
#              FUZZ_CXX (the clang++ to use), FUZZ_MAX_LEN (default 4096),
#              FUZZ_FRESH_CORPUS=1: start from the committed seeds only, in a working directory of
#              this run that is removed when nothing was found (the CTest test fuzz_short does this;
#              by default the working corpus is kept and grows from run to run).
# Exit status: 0 no finding; 1 a finding (crash, sanitizer report, leak, timeout, out-of-memory,
#              contract violation) or a failed build; 77 skipped (no clang++/libFuzzer/cmake).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

seconds=${1:-60}
which=${2:-all}
case "$seconds" in
  '' | *[!0-9]*) echo "fuzz: seconds must be a positive integer, got '$seconds'" >&2; exit 2 ;;
esac
[ "$seconds" -gt 0 ] || { echo "fuzz: seconds must be > 0" >&2; exit 2; }
all_targets=(matrix_market config)
case "$which" in
  all) targets=("${all_targets[@]}") ;;
  matrix_market | config) targets=("$which") ;;
  *) echo "fuzz: unknown target '$which' (matrix_market, config or all)" >&2; exit 2 ;;
esac

skip() {
  echo "fuzz: SKIPPED: $*" >&2
  echo "fuzz: install clang and libFuzzer (Debian: apt-get install clang-14 libclang-rt-14-dev;" \
       "scripts/setup.sh does it)" >&2
  exit 77
}

command -v cmake >/dev/null 2>&1 || skip "cmake not found"
cxx=${FUZZ_CXX:-}
if [ -z "$cxx" ]; then
  for c in clang++ clang++-14; do
    if command -v "$c" >/dev/null 2>&1; then cxx=$(command -v "$c"); break; fi
  done
fi
[ -n "$cxx" ] || skip "clang++ not found"

build=${FUZZ_BUILD_DIR:-build-fuzz}
case "$build" in /*) ;; *) build="$root/$build" ;; esac
mkdir -p "$build"

# Can this clang link a libFuzzer target with both sanitizers? (compiler-rt present)
probe_dir=$(mktemp -d)
trap 'rm -rf "$probe_dir"' EXIT
printf '%s\n' 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' \
  >"$probe_dir/probe.cpp"
if ! "$cxx" -fsanitize=fuzzer,address,undefined "$probe_dir/probe.cpp" -o "$probe_dir/probe" \
     >"$probe_dir/probe.log" 2>&1; then
  cat "$probe_dir/probe.log" >&2
  skip "$cxx cannot link -fsanitize=fuzzer,address,undefined (libFuzzer runtime missing?)"
fi

# Configure and build (serialised between concurrent invocations sharing the build directory).
exec 9>"$build/.build.lock"
flock 9
build_start=$(date +%s)
if [ ! -f "$build/CMakeCache.txt" ]; then
  generator=()
  if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
  cmake -S fuzz -B "$build" "${generator[@]}" -DCMAKE_CXX_COMPILER="$cxx" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo >"$build/configure.log" 2>&1 ||
    { cat "$build/configure.log" >&2; echo "fuzz: FAILED: configure (see above)" >&2; exit 1; }
fi
build_targets=()
for t in "${targets[@]}"; do build_targets+=(--target "fuzz_$t"); done
if ! cmake --build "$build" -j "${FUZZ_JOBS:-2}" "${build_targets[@]}" >"$build/build.log" 2>&1; then
  tail -n 60 "$build/build.log" >&2
  echo "fuzz: FAILED: build (full log: $build/build.log)" >&2
  exit 1
fi
flock -u 9
echo "fuzz: build ready in $(($(date +%s) - build_start)) s ($build)"

max_len=${FUZZ_MAX_LEN:-4096}
if [ "${FUZZ_FRESH_CORPUS:-0}" = 1 ]; then
  work_root="$build/work-fresh-$(date +%Y%m%d-%H%M%S)-$$"
else
  work_root="$build/work"
fi
status=0
for t in "${targets[@]}"; do
  work="$work_root/$t"
  corpus="$work/corpus"
  artifacts="$work/artifacts"
  mkdir -p "$corpus" "$artifacts" "$build/logs"
  # The committed seeds are copied, never used as the output directory.
  cp -n "fuzz/corpus/$t/"* "$corpus/"
  before=$(find "$corpus" -type f | wc -l)
  log="$build/logs/$t-$(date +%Y%m%d-%H%M%S)-$$.log"
  echo "fuzz: $t for $seconds s (corpus $before files, log $log)"
  rc=0
  # A smaller quarantine than ASan's 256 MB default: the fuzzers' RSS otherwise creeps towards
  # -rss_limit_mb in long runs (freed chunks of many size classes held back).
  ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=0:quarantine_size_mb=64:${ASAN_OPTIONS:-}" \
  UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:${UBSAN_OPTIONS:-}" \
    "$build/fuzz_$t" -max_total_time="$seconds" -max_len="$max_len" -rss_limit_mb=2048 \
    -timeout=10 -dict="fuzz/$t.dict" -artifact_prefix="$artifacts/" -print_final_stats=1 \
    "$corpus" >"$log" 2>&1 || rc=$?
  after=$(find "$corpus" -type f | wc -l)
  inited=$(grep -m1 -E '^#[0-9]+[[:space:]]+INITED' "$log" || true)
  last=$(grep -E '^#[0-9]+[[:space:]]+(DONE|NEW|REDUCE|pulse|INITED)' "$log" | tail -n 1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -n 1)
  echo "fuzz: $t: ${inited:-no INITED line}"
  echo "fuzz: $t: ${last:-no status line}"
  echo "fuzz: $t: executions ${execs:-?} (${rate:-?}/s), corpus $before -> $after files," \
       "peak RSS ${rss:-?} MB"
  if [ "$rc" -ne 0 ]; then
    status=1
    echo "fuzz: $t: FAILED (libFuzzer exit $rc); end of the log:" >&2
    tail -n 80 "$log" >&2
    reproducers=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log")
    if [ -n "$reproducers" ]; then
      while IFS= read -r r; do
        echo "fuzz: $t: reproducer: $r" >&2
        echo "fuzz: $t: re-run it: $build/fuzz_$t $r" >&2
      done <<<"$reproducers"
    else
      echo "fuzz: $t: no reproducer written; full log: $log" >&2
    fi
  fi
done
if [ "$status" -ne 0 ]; then
  echo "fuzz: FAILED: see the reproducers above; add each fixed one to fuzz/corpus/<target>/" \
       "and as a unit test (docs/fuzzing.md)" >&2
elif [ "${FUZZ_FRESH_CORPUS:-0}" = 1 ]; then
  rm -rf "$work_root"
fi
exit "$status"
