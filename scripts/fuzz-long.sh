#!/usr/bin/env bash
# The documented long fuzzing run (docs/reliability.md, "Fuzzing"): builds the
# `fuzz` preset, then runs every libFuzzer target for SECONDS each (default
# 300; 15 targets x 300 s = 75 CPU-minutes), one after the other on one core,
# each from a copy of its seed corpus (fuzz/corpus/<target>/). Prints per
# target the executions, coverage (cov:) and features (ft:) from libFuzzer's
# final stats and whether it found anything (a crash, a leak, a sanitizer
# report, a timeout or an out-of-memory: the fuzzer's exit code, and any
# crash-/leak-/timeout-/oom- file). Logs, grown corpora and reproducers stay
# in build/fuzz/long/<target>/.
# Usage: scripts/fuzz-long.sh [SECONDS]    scripts/fuzz-long.sh --list (the targets, for CI)
# Exit status: 0 when no target found anything, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."

targets=(fuzz_rtu_framer fuzz_slave_engine fuzz_pdu_codec fuzz_mbap fuzz_master_response
         fuzz_inverjet_machine fuzz_rehand_chair fuzz_rehand_session fuzz_device_engine fuzz_map_file fuzz_plan_file
         fuzz_state_file fuzz_mqtt_command fuzz_host_message fuzz_gateway_request fuzz_ble_gatt)

if [ "${1:-}" = "--list" ]; then
  printf '%s\n' "${targets[@]}"
  exit 0
fi
seconds="${1:-300}"
case "$seconds" in
  '' | *[!0-9]*) echo "usage: scripts/fuzz-long.sh [SECONDS] | --list" >&2; exit 2 ;;
esac

cmake --preset fuzz >/dev/null
cmake --build --preset fuzz

out=build/fuzz/long
mkdir -p "$out"
found_any=0
rows=()
for target in "${targets[@]}"; do
  dir="$out/$target"
  rm -rf "$dir"
  mkdir -p "$dir/corpus" "$dir/artifacts"
  if [ -d "fuzz/corpus/$target" ]; then cp -r "fuzz/corpus/$target/." "$dir/corpus"; fi
  echo "=== $target: ${seconds} s" >&2
  status=0
  build/fuzz/fuzz/$target -max_total_time="$seconds" -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/" "$dir/corpus" >"$dir/log" 2>&1 || status=$?
  # The last status line ("#N DONE cov: C ft: F corp: ...", or the last one
  # before a crash) and the final stats.
  last=$(grep -E '^#[0-9]+.*cov: ' "$dir/log" | tail -n 1 || true)
  cov=$(sed -nE 's/.* cov: ([0-9]+).*/\1/p' <<<"$last")
  ft=$(sed -nE 's/.* ft: ([0-9]+).*/\1/p' <<<"$last")
  execs=$(sed -nE 's/^stat::number_of_executed_units: ([0-9]+)/\1/p' "$dir/log" | tail -n 1)
  rate=$(sed -nE 's/^stat::average_exec_per_sec: +([0-9]+)/\1/p' "$dir/log" | tail -n 1)
  corpus=$(find "$dir/corpus" -type f | wc -l)
  artifacts=$(find "$dir/artifacts" -type f | wc -l)
  if [ "$status" -ne 0 ] || [ "$artifacts" -ne 0 ]; then
    result="FOUND (exit $status, $artifacts file(s) in $dir/artifacts; see $dir/log)"
    found_any=1
  else
    result="nothing"
  fi
  rows+=("$(printf '%-22s %6s %12s %8s %6s %7s %7s  %s' "$target" "$seconds" "${execs:-?}" "${rate:-?}" \
    "${cov:-?}" "${ft:-?}" "$corpus" "$result")")
done

printf '%-22s %6s %12s %8s %6s %7s %7s  %s\n' target seconds execs exec/s cov ft corpus found
printf '%s\n' "${rows[@]}"
echo "total: ${#targets[@]} targets x ${seconds} s = $((${#targets[@]} * seconds)) CPU-seconds"
exit "$found_any"
