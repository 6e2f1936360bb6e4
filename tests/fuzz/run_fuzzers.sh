#!/usr/bin/env bash
# `make fuzz`: runs each libFuzzer harness of BUILD for SECONDS, one after the other, seeded with the
# corpus of tests/fuzz/<kind>/. Prints the executions of each; a finding (crash, sanitizer report,
# timeout (60 s an input: generous, since instrumented code at nice 19 on a busy machine is
# 50x slower than a release build), memory over the limit) is kept in BUILD/fuzz-findings/<harness>/ and fails the run.
# Usage: tests/fuzz/run_fuzzers.sh BUILD SECONDS [HARNESS...]
set -uo pipefail
build=$1 seconds=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
declare -A seeds=([toml]="port camera lens" [pointcloud]="ply stl obj xyz" [calib_json]="calib_json"
                  [opencv_yaml]="yaml" [metashape_xml]="metashape" [opencv_xml]="opencv_xml" [colmap_text]="colmap" [colmap_binary]="colmap_bin" [mrcal]="mrcal" [calibmar]="yaml" [detections]="detections" [gnuplot_text]="port" [image_header]="images" [target_field]="field")
harnesses=("$@")
[ ${#harnesses[@]} -eq 0 ] && harnesses=(toml pointcloud calib_json opencv_yaml metashape_xml opencv_xml colmap_text colmap_binary mrcal calibmar detections gnuplot_text image_header target_field)
status=0
for h in "${harnesses[@]}"; do
  bin="$build/tests/fuzz/fuzz_$h"
  [ -x "$bin" ] || { echo "fuzz: $bin not built" >&2; status=1; continue; }
  corpus="$build/fuzz-corpus/$h" findings="$build/fuzz-findings/$h"
  mkdir -p "$corpus" "$findings"
  dirs=()
  for k in ${seeds[$h]}; do dirs+=("$here/$k"); done
  log="$build/fuzz-$h.log"
  "$bin" -max_total_time="$seconds" -timeout=60 -rss_limit_mb=2048 -max_len=262144 -print_final_stats=1 \
         -artifact_prefix="$findings/" "$corpus" "${dirs[@]}" >"$log" 2>&1
  rc=$?
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$')
  echo "fuzz_$h: ${execs:-?} executions in ${seconds} s, exit $rc$( [ $rc -ne 0 ] && echo ": FINDING, see $log and $findings")"
  [ $rc -ne 0 ] && status=1
done
exit $status
