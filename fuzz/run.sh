#!/usr/bin/env bash
# fuzz/run.sh — run every fuzz target (or the ones named) for SECONDS each, one after the other,
# at the lowest CPU priority; fail when any reports a finding. Usage:
#   fuzz/run.sh <build dir> <seconds per target> [target...]
# Each target starts from its seeds (fuzz/corpus/<target>, never written) plus what earlier runs
# in this build found (<build dir>/fuzz/corpus/<target>, where new inputs go). A finding's input is
# saved as <build dir>/fuzz/findings/<target>-crash-..., -leak-..., -timeout-..., -oom-...; a
# table of the runs (seconds, executions, coverage, features, corpus, result) is appended to
# <build dir>/fuzz/stats.tsv (cpu_seconds: what the fuzzer got of the wall-clock seconds at nice 19,
# the figure for totals on a shared machine). A hang is an input running past FUZZ_TIMEOUT (60) s of wall-clock
# time: at nice 19 on a loaded 2-core machine, 10 s flagged inputs that take 0.3 s of CPU.
# FUZZ_RUNS=N (what .ci/run sets): N inputs per target from the fixed seed 1, SECONDS only a bound —
# the same inputs on every run, so CI passes or fails on the code, not on what a random seed found
# that day; `make fuzz` without it explores afresh each time.
set -uo pipefail
cd "$(dirname "$0")/.."
build=${1:?usage: fuzz/run.sh <build dir> <seconds per target> [target...]}
seconds=${2:?usage: fuzz/run.sh <build dir> <seconds per target> [target...]}
shift 2
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(fuzz_surface_obj fuzz_surface_ply fuzz_surface_stl fuzz_surface_off fuzz_gmsh fuzz_tetgen fuzz_vtk
           fuzz_scene fuzz_predictor fuzz_trajectory_csv fuzz_recording_csv fuzz_spring_cut fuzz_charged_cut)
fi
work="$build/fuzz"
mkdir -p "$work/findings" "$work/logs"
[ -f "$work/stats.tsv" ] || printf 'date\ttarget\tseconds\tcpu_seconds\texecutions\tcov\tft\tcorpus\tresult\n' > "$work/stats.tsv"
# Leaks inside Debian's Gmsh, assimp and Mesa only (tests/lsan.supp says why); UBSan stops at its
# first report; a huge allocation is an out-of-memory finding, not a swap storm.
export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export ASAN_OPTIONS="${ASAN_OPTIONS:-}:allocator_may_return_null=0:detect_leaks=1"
failed=()
for t in "${targets[@]}"; do
  bin="$build/fuzz/$t"
  [ -x "$bin" ] || { echo "fuzz: $bin is not built (cmake --build --preset fuzz --target fuzz_targets)" >&2; exit 2; }
  mkdir -p "$work/corpus/$t"
  log="$work/logs/$t.log"
  start=$(date +%s)
  # Bounded from outside too: libFuzzer's out-of-memory report prints a heap profile first, and on
  # gigabytes of small blocks under ASan that took over 5 minutes (a 10 s CI run of fuzz_scene hung
  # there); past the grace the fuzzer is killed and that counts as a finding (the input is lost:
  # rerun the target alone with -rss_limit_mb=0 -malloc_limit_mb=200 to catch it as it allocates).
  cpu_file="$work/logs/$t.cpu"
  TIMEFORMAT='%U %S'
  { time timeout --kill-after=10 "$((seconds + ${FUZZ_GRACE:-120}))" \
    nice -n 19 "$bin" -max_total_time="$seconds" ${FUZZ_RUNS:+-runs="$FUZZ_RUNS" -seed=1} \
    -timeout="${FUZZ_TIMEOUT:-60}" -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -print_final_stats=1 -artifact_prefix="$work/findings/$t-" "$work/corpus/$t" "fuzz/corpus/$t" > "$log" 2>&1 ; } 2> "$cpu_file"
  rc=$?
  cpu=$(awk '{printf "%d", $1 + $2}' "$cpu_file" 2>/dev/null)
  took=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last"); ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9]*[a-zA-Z]*\).*/\1/p' <<<"$last")
  result=ok; [ $rc -eq 0 ] || result="FINDING (exit $rc)"
  [ $rc -eq 124 ] || [ $rc -eq 137 ] && result="FINDING (killed past ${seconds} s + ${FUZZ_GRACE:-120} s of grace)"
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$t" "$took" "${cpu:-?}" "${execs:-?}" "${cov:-?}" "${ft:-?}" \
    "${corp:-?}" "$result" >> "$work/stats.tsv"
  printf 'fuzz: %-22s %4ss (cpu %ss) %9s runs  cov %-5s ft %-6s corpus %-10s %s\n' "$t" "$took" "${cpu:-?}" "${execs:-?}" "${cov:-?}" \
    "${ft:-?}" "${corp:-?}" "$result"
  if [ $rc -ne 0 ]; then
    failed+=("$t")
    grep -E 'ERROR|SUMMARY|fuzz:|Test unit written|deadly|Timeout|out-of-memory' "$log" | head -20 >&2
    echo "fuzz: $t: the whole log is $log" >&2
  fi
done
if [ ${#failed[@]} -ne 0 ]; then
  echo "fuzz: findings in ${failed[*]} (inputs in $work/findings/)" >&2
  exit 1
fi
