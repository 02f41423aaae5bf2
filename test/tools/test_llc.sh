#!/usr/bin/env bash
# The llc tool as a user meets it: clear one-line errors with non-zero exits, and a whole
# pairs -> features -> train -> score -> evaluate round on a real log when ../shared/data is there.
set -uo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
LLC="$REPO/build/.ws/devel/lib/laser_loop_closure/llc"
DATA="${LLC_DATA_DIR:-$REPO/../shared/data}"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
passed=0 failed=0

check() {  # check NAME EXPECTED_EXIT PATTERN -- command...
  local name="$1" want="$2" pattern="$3"; shift 4
  local out rc
  out="$("$@" 2>&1)"; rc=$?
  if [ "$rc" -eq "$want" ] && grep -qE -- "$pattern" <<<"$out"; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1))
    echo "FAIL: $name (exit $rc, wanted $want; output below)"; echo "$out" | tail -5
  fi
}

check "no subcommand" 2 "usage: llc" -- "$LLC"
check "unknown subcommand" 2 "unknown subcommand" -- "$LLC" fly
check "unknown option" 2 "unknown option --bogus" -- "$LLC" pairs --bogus 1
check "missing log" 1 "no such file" -- "$LLC" pairs --log "$TMP/none.log" --out "$TMP/p.csv"
check "bad feature set" 2 "must be 'paper' or 'extended'" -- "$LLC" features --log x --out y --features/set fancy
check "feature option: not a boolean" 2 "--features/closed_ring must be true or false" -- "$LLC" features --log x --out y --features/closed_ring maybe
printf '# t1 t2 x y z roll pitch yaw\n1 2 3 4 5 6 7\n' > "$TMP/short.relations"
check "relations: a line of 7 values" 1 "short.relations:2: 7 values, not the 8" -- "$LLC" relations --log x --poses y --relations "$TMP/short.relations"
check "relations: both --poses and --keyframes" 2 "exactly one of --poses and --keyframes" -- "$LLC" relations --log x --poses y --keyframes z --relations r
check "slam --relations: a missing file, before the run" 1 "none.relations: cannot be read" -- "$LLC" slam --log x --out "$TMP/none" --relations "$TMP/none.relations"
printf 'FLASER 3 1 2\n' > "$TMP/bad.log"
check "malformed log" 1 "bad.log:1: FLASER" -- "$LLC" features --log "$TMP/bad.log" --out "$TMP/f.csv"
printf 'not a model\n' > "$TMP/bad.yaml"
check "corrupt model" 1 "classifier model .*bad.yaml" -- "$LLC" score --model "$TMP/bad.yaml" --data "a:b" --out "$TMP/s.csv"
check "default model loads" 1 "no such file" -- "$LLC" score --data "$TMP/none.log:$TMP/none.csv" --out "$TMP/s.csv"

# The simulator: bad arguments, then a short drive that the other subcommands read.
check "simulate negative length" 2 "length-m must be a positive" -- "$LLC" simulate --out "$TMP/sim" --length-m -5
check "simulate unknown scanner" 2 "scanners must be" -- "$LLC" simulate --out "$TMP/sim" --scanners left
check "simulate unwritable dir" 1 "cannot (create|write)" -- "$LLC" simulate --out /proc/llc-sim --length-m 100
check "simulate" 0 "x real time" -- "$LLC" simulate --out "$TMP/sim" --length-m 600 --seed 1
# The whole pipeline on the short drive: files, their headers, and what it must achieve.
check "slam on sim.bag" 0 "^wrong_loops_accepted=0$" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam" --quiet --save-session "$TMP/sim.llcsession" --save-graph "$TMP/slam.g2o"
# --save-graph: a vertex per keyframe at its optimised pose (as trajectory.csv), an edge per
# keyframe step and per applied loop; llc graph --batch finds those poses at the optimum.
check "slam --save-graph: a vertex per keyframe, an edge per step and per applied loop" 0 "^ok$" -- bash -c "awk -F= '{v[\$1] = \$2} END {print v[\"keyframes\"], v[\"keyframes\"] - 1 + v[\"loops_accepted\"]}' '$TMP/slam/report.txt' > '$TMP/g2o_want'; echo \$(grep -c '^VERTEX_SE2 ' '$TMP/slam.g2o') \$(grep -c '^EDGE_SE2 ' '$TMP/slam.g2o') | cmp -s - '$TMP/g2o_want' && echo ok"
check "slam --save-graph: the vertices are trajectory.csv's poses" 0 "^ok$" -- bash -c "paste -d' ' <(tail -n +2 '$TMP/slam/trajectory.csv' | tr , ' ') <(grep '^VERTEX_SE2 ' '$TMP/slam.g2o') | awk '{d = (\$3 - \$8) ^ 2 + (\$4 - \$9) ^ 2 + (\$5 - \$10) ^ 2; if (d > 1e-10) bad++} END {print (NR > 300 && !bad ? \"ok\" : \"not ok\")}'"
check "slam --save-graph: llc graph --batch stays at the run's optimum" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/slam.g2o' --out '$TMP/slam_batch.g2o' --batch | awk '/initial_chi2=/ {sub(/.*initial_chi2=/, \"\"); a = \$1 + 0} /^chi2=/ {sub(/^chi2=/, \"\"); b = \$1 + 0} END {print (a > 0 && b <= a && b > 0.99 * a ? \"ok\" : \"not ok: \" a \" -> \" b)}'"
check "slam trajectory header" 0 "^index,stamp,x,y,theta$" -- head -1 "$TMP/slam/trajectory.csv"
check "slam loops header" 0 "^a,b,accepted,score,inlier_share,x,y,theta,innovation_chi2,by_consensus,refusal,reason$" -- head -1 "$TMP/slam/loops.csv"
# Every refused candidate says at which stage (the refusal column) and why; an applied one says nothing.
check "slam loops: a reason for each refused one, none for an applied one" 0 "^ok [1-9][0-9]* [1-9][0-9]*$" -- awk -F, '
    NR > 1 { r = substr($0, index($0, "\"")); if ($3 == 1) { applied++; if (r != "\"\"" || $11 != "none") bad++ } else { refused++; if (r !~ /^"(validation|context|backend|crf|icp|alignment)[^"]*: [^"]+"$/ || $11 !~ /^(validation|context|back_end_[a-z]+|crf_match|icp|place_gate)$/) bad++ } }
    END { print (bad ? "not ok " bad : "ok " applied " " refused) }' "$TMP/slam/loops.csv"
# A loop that reached the back end carries its aligned pose and a chi-square on the right side
# of the gate (16.27, config/slam.yaml); a candidate refused before it carries none.
check "slam loops: pose and chi2 exactly for the loops the back end weighed" 0 "^ok [1-9][0-9]* [0-9]*$" -- awk -F, '
    NR > 1 { r = substr($0, index($0, "\"")); posed = ($6 != "" && $7 != "" && $8 != "" && $9 != "")
             if ($3 == 1) { applied++; if (!posed || $9 + 0 > 16.27 || $8 + 0 > 3.1416 || $8 + 0 < -3.1416) bad++ }
             else if (r ~ /^"backend: innovation/) { gated++; if (!posed || $9 + 0 <= 16.27) bad++ }
             else if ($6 $7 $8 $9 != "") bad++ }
    END { print (bad ? "not ok " bad : "ok " applied " " gated + 0) }' "$TMP/slam/loops.csv"
# by_consensus is 0 or 1, and 1 only on an applied loop.
check "slam loops: by_consensus only on applied loops" 0 "^ok$" -- awk -F, '
    NR > 1 { if (($10 != 0 && $10 != 1) || ($10 == 1 && $3 != 1)) bad++ }
    END { print (bad ? "not ok " bad : "ok") }' "$TMP/slam/loops.csv"
check "slam map files" 0 "^image: map.pgm$" -- bash -c "test -s '$TMP/slam/map.pgm' && test -s '$TMP/slam/map.png' && cat '$TMP/slam/map.yaml'"
check "slam: < 0.5 m RMS, odometry > 2 m, >= 80% of true loops closed" 0 "^ok$" -- awk -F= '
  {v[$1] = $2}
  END {ok = v["rms_error_m"] < 0.5 && v["rms_error_odometry_m"] > 2 && v["true_loop_keyframes"] > 20 &&
            v["true_loop_keyframes_closed"] >= 0.8 * v["true_loop_keyframes"]
       print (ok ? "ok" : "not ok: rms " v["rms_error_m"] " closed " v["true_loop_keyframes_closed"] "/" v["true_loop_keyframes"])}' "$TMP/slam/report.txt"
check "slam: every refusal counted by its stage's name, and the counts add up" 0 "^ok$" -- awk -F'[= ]' '
    {v[$1] = $2} END {stages = v["candidates_refused_crf_match"] + v["candidates_refused_icp"] + v["candidates_refused_validation"];
                      back = v["candidates_refused_back_end_gate"] + v["candidates_refused_back_end_unsolvable"] + v["candidates_refused_back_end_malformed"];
       print (("candidates_refused_other" in v) && v["candidates_refused_other"] == 0 && v["candidates_refused_place_gate"] == v["candidates_not_aligned"] &&
              stages == v["loops_refused_by_alignment"] && back == v["loops_refused_by_gate"] &&
              ("loops_refused_by_context" in v) && v["candidates_refused_context"] == v["loops_refused_by_context"] &&
              v["context_checked"] >= v["loops_refused_by_context"] ? "ok" : "not ok")}' "$TMP/slam/report.txt"
check "slam: the place gate spared alignments but skipped no true revisit" 0 "^ok$" -- awk -F= '
    {v[$1] = $2} END {print (v["candidates_not_aligned"] + 0 > 0 && ("true_pairs_not_aligned" in v) && v["true_pairs_not_aligned"] + 0 == 0 ? "ok" : "not ok: " v["candidates_not_aligned"] " / " v["true_pairs_not_aligned"])}' "$TMP/slam/report.txt"
# Drifted odometry (a real log's perfect odometry made to drift like a wheelbase), the truth kept.
check "slam --drift strong on sim.log: drift said, truth kept" 0 "^ok$" -- bash -c "'$LLC' slam --log '$TMP/sim/sim.log' --out '$TMP/slam_drift' --quiet --drift strong --drift-seed 3 --save-graph '$TMP/slam_drift.g2o' | grep -q '^odometry_drift: scale_bias=0.03 heading_drift=0.01 ' && awk -F= '{v[\$1] = \$2} END {print (v[\"rms_error_odometry_m\"] > v[\"rms_error_m\"] && v[\"true_loop_keyframes\"] > 0 ? \"ok\" : \"not ok\")}' '$TMP/slam_drift/report.txt'"
# --truth: the log as its own reference gives every scan its own true pose back, through the
# rear scans merged and the scanners' offsets (so the same RMS as the run above), and no
# pose needs carrying.
check "slam --truth: the log itself as the reference" 0 "^truth_scans_carried=0 " -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_truth" --quiet --drift strong --drift-seed 3 --truth "$TMP/sim/sim.log"
check "slam --truth: the same RMS as the log's own truth" 0 "^rms_error_m=$(sed -n 's/^rms_error_m=//p' "$TMP/slam_drift/report.txt")$" -- cat "$TMP/slam_truth/report.txt"
check "slam --truth: truth.csv" 0 "^index,stamp,x,y,theta,matched$" -- head -1 "$TMP/slam_truth/truth.csv"
# A drifted run writes the truth it was judged against too: the log's own poses, as --truth with
# the log as its own reference gives them.
check "slam --drift: truth.csv as --truth writes it" 0 "^ok$" -- bash -c "cmp '$TMP/slam_drift/truth.csv' '$TMP/slam_truth/truth.csv' && echo ok"
# scripts/lib/graph_oracle.py: the saved graph solved again gives the run's RMS; with every step
# the truth's only the loops' error is left; a heading noise per step makes it worse.
check "graph_oracle: the run's RMS, less with the truth's steps, more with noise" 0 "^ok$" -- bash -c "/usr/bin/python3 '$REPO/scripts/lib/graph_oracle.py' '$TMP/slam_drift' '$TMP/slam_drift.g2o' --keyframes 5,6 --noise-rad 0.003 --seeds 3 --llc '$LLC' | awk -v run=\$(sed -n 's/^rms_error_m=//p' '$TMP/slam_drift/report.txt') '/^noise .*median/ {n = \$0; sub(/.*median rms_error_m=/, \"\", n); noise = n + 0; next} {for (i = 1; i <= NF; i++) if (\$i ~ /^rms_error_m=/) {sub(/rms_error_m=/, \"\", \$i); v[\$1] = \$i + 0}} END {ok = v[\"saved\"] > 0.8 * run && v[\"saved\"] < 1.2 * run && v[\"reference_steps\"] < 0.5 * v[\"saved\"] && (\"reference_listed(2)\" in v) && noise > 2 * v[\"saved\"]; print (ok ? \"ok\" : \"not ok: run \" run \" saved \" v[\"saved\"] \" steps \" v[\"reference_steps\"] \" noise \" noise)}'"
check "graph_oracle: another run's graph" 1 "graph_oracle: .* poses, .* keyframes \(not the same run\?\)" -- /usr/bin/python3 "$REPO/scripts/lib/graph_oracle.py" "$TMP/slam_drift" "$TMP/slam.g2o" --llc "$LLC"
mkdir -p "$TMP/go_notruth" && cp "$TMP/slam_drift/trajectory.csv" "$TMP/go_notruth/"
check "graph_oracle: a run without truth.csv" 1 "graph_oracle: cannot read .*truth.csv" -- /usr/bin/python3 "$REPO/scripts/lib/graph_oracle.py" "$TMP/go_notruth" "$TMP/slam_drift.g2o" --llc "$LLC"
check "graph_oracle: --noise-rad -1" 2 "graph_oracle: --noise-rad: bad value -1" -- /usr/bin/python3 "$REPO/scripts/lib/graph_oracle.py" "$TMP/slam_drift" "$TMP/slam_drift.g2o" --noise-rad -1
check "graph_oracle: a step that is not in the graph" 1 "graph_oracle: no step edge into keyframe\(s\) 99999" -- /usr/bin/python3 "$REPO/scripts/lib/graph_oracle.py" "$TMP/slam_drift" "$TMP/slam_drift.g2o" --keyframes 99999 --llc "$LLC"
# scripts/lib/error_along_path.py aligns the keyframes to the truth as llc slam does: the same RMS.
check "slam: odometry_steps.csv's tracked column counts the report's odometry_steps_tracked (> 0)" 0 "^ok$" -- bash -c "awk -F, 'NR == 1 {for (i = 1; i <= NF; i++) if (\$i == \"tracked\") c = i} NR > 1 && c {s += \$c} END {print s}' '$TMP/slam_truth/odometry_steps.csv' > '$TMP/tracked_rows'; n=\$(sed -n 's/^odometry_steps_tracked=\([0-9]*\).*/\1/p' '$TMP/slam_truth/report.txt'); [ \"\$n\" -gt 0 ] && [ \"\$n\" = \"\$(cat '$TMP/tracked_rows')\" ] && echo ok"
check "tracked_steps: the tracked count of the report, and blocks of keyframes" 0 "^ok$" -- bash -c "/usr/bin/python3 '$REPO/scripts/lib/tracked_steps.py' '$TMP/slam_truth' '$TMP/slam_truth' --block 50 > '$TMP/tracked_steps.txt' && n=\$(sed -n 's/^odometry_steps_tracked=\([0-9]*\).*/\1/p' '$TMP/slam_truth/report.txt') && grep -q \"^tracked: \$n steps, .*; the same steps in the other run: \$n steps\" '$TMP/tracked_steps.txt' && grep -q '^keyframes 1-50: .*(difference +0.0000)' '$TMP/tracked_steps.txt' && echo ok"
check "tracked_steps: a run without odometry_steps.csv" 1 "tracked_steps: cannot read" -- /usr/bin/python3 "$REPO/scripts/lib/tracked_steps.py" "$TMP/none_run"
mkdir -p "$TMP/untracked_run" && cut -d, -f1-17 "$TMP/slam_truth/odometry_steps.csv" > "$TMP/untracked_run/odometry_steps.csv"
check "tracked_steps: a file without the tracked column" 1 "has no tracked column" -- /usr/bin/python3 "$REPO/scripts/lib/tracked_steps.py" "$TMP/untracked_run"
check "tracked_steps: --block 0" 2 "must be a whole number >= 1" -- /usr/bin/python3 "$REPO/scripts/lib/tracked_steps.py" "$TMP/slam_truth" --block 0
check "error_along_path: llc slam's RMS" 0 "^rms_error_m=$(sed -n 's/^rms_error_m=//p' "$TMP/slam_truth/report.txt") over " -- /usr/bin/python3 "$REPO/scripts/lib/error_along_path.py" "$TMP/slam_truth"
mkdir -p "$TMP/eap_notruth" && cp "$TMP/slam_truth/"{trajectory,loops}.csv "$TMP/eap_notruth/"
check "error_along_path: a run without truth.csv" 1 "error_along_path: .*truth.csv" -- /usr/bin/python3 "$REPO/scripts/lib/error_along_path.py" "$TMP/eap_notruth"
mkdir -p "$TMP/eap_nan" && cp "$TMP/slam_truth/"{truth,loops}.csv "$TMP/eap_nan/" && sed '3s/^\([^,]*\),\([^,]*\),[^,]*,/\1,\2,nan,/' "$TMP/slam_truth/trajectory.csv" > "$TMP/eap_nan/trajectory.csv"
check "error_along_path: a pose of nan" 1 "error_along_path: .*not finite" -- /usr/bin/python3 "$REPO/scripts/lib/error_along_path.py" "$TMP/eap_nan"
check "error_along_path: --block 0" 2 "must be whole numbers >= 1" -- /usr/bin/python3 "$REPO/scripts/lib/error_along_path.py" "$TMP/slam_truth" --block 0
# scripts/lib/triangle_closure.py: on the simulated drive ICP's steps close their triangles and
# agree with the truth to well under a milliradian (real 180-degree logs: several milliradians).
check "triangle_closure: the simulated drive's steps close" 0 "^ok$" -- bash -c "/usr/bin/python3 '$REPO/scripts/lib/triangle_closure.py' '$TMP/slam_truth' '$TMP/sim/sim.log' --llc '$LLC' | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"triangles\"] > 100 && v[\"triangles_gross\"] < 0.05 * v[\"triangles\"] && v[\"closure_heading_rms_rad\"] < 0.001 && v[\"truth_heading_rms_rad\"] < 0.001 ? \"ok\" : \"not ok\")}'"
check "triangle_closure: a run without trajectory.csv" 1 "triangle_closure: no .*trajectory.csv" -- /usr/bin/python3 "$REPO/scripts/lib/triangle_closure.py" "$TMP/none_run" "$TMP/sim/sim.log"
# scripts/lib/step_truth_check.py: the simulated drive's truth is exact, so no step is degrees off
# it and ICP from the truth's own step hardly moves; a step made 5.7 degrees off (the first 20
# keyframes' steps, one edited) is listed, and the scans side with the truth there, not the run.
check "step_truth_check: the simulated drive's steps agree with its truth" 0 "^ok$" -- bash -c "/usr/bin/python3 '$REPO/scripts/lib/step_truth_check.py' '$TMP/slam_truth' '$TMP/sim/sim.log' --llc '$LLC' | awk -F'[= ]' '{for (i = 1; i < NF; i += 2) v[\$i] = \$(i + 1)} END {print (v[\"steps\"] > 300 && v[\"steps_aligned_from_reference\"] == v[\"steps\"] && v[\"steps_off_by_min_deg\"] == 0 && v[\"icp_move_from_reference_deg_median\"] < 0.05 ? \"ok\" : \"not ok\")}'"
mkdir -p "$TMP/stc_edit" && head -21 "$TMP/slam_truth/odometry_steps.csv" | awk -F, 'BEGIN {OFS = ","} NR > 1 && $1 == 5 {$10 = 0.1} {print}' > "$TMP/stc_edit/odometry_steps.csv"
check "step_truth_check: a step made 5.7 degrees off is listed, the scans with the truth" 0 "^5,[0-9]+,[0-9]+,5.73,[0-9.]+,0.[0-9]+,[0-9.]+,[0-9.]+,0$" -- /usr/bin/python3 "$REPO/scripts/lib/step_truth_check.py" "$TMP/stc_edit" "$TMP/sim/sim.log" --llc "$LLC"
check "step_truth_check: the counts" 0 "^steps_off_by_min_deg=1 " -- /usr/bin/python3 "$REPO/scripts/lib/step_truth_check.py" "$TMP/stc_edit" "$TMP/sim/sim.log" --llc "$LLC"
check "step_truth_check: a run without odometry_steps.csv" 1 "step_truth_check: no .*odometry_steps.csv" -- /usr/bin/python3 "$REPO/scripts/lib/step_truth_check.py" "$TMP/none_run" "$TMP/sim/sim.log"
check "step_truth_check: --min-deg -1" 2 "step_truth_check: --min-deg must be a number >= 0" -- /usr/bin/python3 "$REPO/scripts/lib/step_truth_check.py" "$TMP/stc_edit" "$TMP/sim/sim.log" --min-deg -1
check "step_truth_check: no such log" 1 "step_truth_check: no log " -- /usr/bin/python3 "$REPO/scripts/lib/step_truth_check.py" "$TMP/stc_edit" "$TMP/no_such.log"
# scripts/lib/wall_directions.py: the simulated town's walls meet at right angles, so by its
# truth (the TRUEPOS after each FLASER) every block's walls keep one direction, and the run's
# heading (0.5 m RMS at most) stays with them. The FLASER poses (odometry) would be degrees off.
check "wall_directions: the simulated town's walls straight, the run's heading with them" 0 "^ok [1-9]" -- bash -c "/usr/bin/python3 '$REPO/scripts/lib/wall_directions.py' '$TMP/slam_truth' '$TMP/sim/sim.log' --block 100 | awk -F, 'NR > 2 { n++; r = \$3 < 0 ? -\$3 : \$3; h = \$7 < 0 ? -\$7 : \$7; if (r > 0.5 || h > 0.5) bad++ } END { print (n && !bad ? \"ok \" n : \"not ok: \" bad \" of \" n \" blocks\") }'"
check "wall_directions: --block 0" 2 "wall_directions: --block 0: --block must be a whole number >= 1" -- /usr/bin/python3 "$REPO/scripts/lib/wall_directions.py" "$TMP/slam_truth" "$TMP/sim/sim.log" --block 0
check "wall_directions: a run without trajectory.csv" 1 "wall_directions: .*trajectory.csv" -- /usr/bin/python3 "$REPO/scripts/lib/wall_directions.py" "$TMP/none_run" "$TMP/sim/sim.log"
printf 'FLASER 10 1 1 1 1 1 1 1 1 1 1 0 0 0 0 0 0 1.0 host 1.0\nFLASER 10 1 1 1 1 1 1 1 1 1 1 0 0 0 0 0 0 2.0 host 2.0\n' > "$TMP/two_scans.log"
check "wall_directions: keyframes of another log" 1 "wall_directions: keyframe index [0-9]+: the log has 2 FLASER scans" -- /usr/bin/python3 "$REPO/scripts/lib/wall_directions.py" "$TMP/slam_truth" "$TMP/two_scans.log"
printf 'FLASER 3 1 2 3 0 0 0 0 0 0 1.0 host 1.0\n' > "$TMP/three_beams.log"
check "wall_directions: a scan of 3 beams" 1 "wall_directions: .*three_beams.log:1: FLASER with 3 beams" -- /usr/bin/python3 "$REPO/scripts/lib/wall_directions.py" "$TMP/slam_truth" "$TMP/three_beams.log"
# scripts/lib/enclosed_scans.py on a hand-made log: scan 1 has every return of both scanners
# within 2 m (a car over the robot), scan 2 only its front one (the rear sees 9 m), scan 3 none.
{ printf 'FLASER 3 5 6 7 0 0 0 0 0 0 0 host 0\nRLASER 3 5 6 7 0 0 0 0 0 0 0 host 0\n'
  printf 'FLASER 3 0.5 1.5 80 0 0 0 0 0 0 1 host 1\nRLASER 3 0.04 1 1.2 0 0 0 0 0 0 1 host 1\n'
  printf 'FLASER 3 1 1 1 0 0 0 0 0 0 2 host 2\nRLASER 3 1 9 1 0 0 0 0 0 0 2 host 2\n'
  printf 'FLASER 3 80 80 80 0 0 0 0 0 0 3 host 3\nRLASER 3 80 0 80 0 0 0 0 0 0 3 host 3\n'; } > "$TMP/enclosed.log"
check "enclosed_scans: the scan whose every return is near on both scanners" 0 "enclosed.log: scans=4 enclosed=1 runs=1$" -- /usr/bin/python3 "$REPO/scripts/lib/enclosed_scans.py" "$TMP/enclosed.log"
check "enclosed_scans: a wider distance takes the front-only one too" 0 "enclosed.log: scans=4 enclosed=3 runs=0-2$" -- /usr/bin/python3 "$REPO/scripts/lib/enclosed_scans.py" --distance 10 "$TMP/enclosed.log"
printf 'FLASER 3 1 1\n' > "$TMP/enclosed_short.log"
check "enclosed_scans: a laser line short of its ranges" 1 "enclosed_short.log:1: 3 ranges announced, 2 given" -- /usr/bin/python3 "$REPO/scripts/lib/enclosed_scans.py" "$TMP/enclosed_short.log"
check "enclosed_scans: --distance 0" 2 "must be > 0" -- /usr/bin/python3 "$REPO/scripts/lib/enclosed_scans.py" --distance 0 "$TMP/enclosed.log"
# scripts/lib/relation_tail.py on a hand-made run: relation 4 (5 m) spans keyframes 0 -> 2,
# whose step 2 no scan placed and whose step 1 was widened to 3.5 m; without it the mean is 0.2.
mkdir -p "$TMP/tail"
printf 'relation,t1,t2,scan1,scan2,translation_m,rotation_deg,carried\n1,0,1,0,1,0.1,1,0\n2,1,2,1,2,0.3,1,0\n3,3,4,3,4,0.2,1,0\n4,2,7,2,7,5.0,2,0\n' > "$TMP/tail/relation_errors.csv"
{ echo 'scan,stamp,x,y,theta,keyframe'; for i in 0 1 2 3 4 5 6 7 8 9; do echo "$i,$i,0,0,0,$((i < 3 ? 0 : i < 6 ? 1 : 2))"; done; } > "$TMP/tail/scans.csv"
check "relation_tail: without odometry_steps.csv" 0 "^4,2,7,0,2,5,2,2,-,-$" -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/tail" --top 1
printf 'keyframe,scan_index,matched,overlap_share,dx,dy,dtheta,error_x,error_y,error_theta,sigma_x,sigma_y,sigma_theta,wheel_dx,wheel_dy,wheel_dtheta,ambiguous_shift_m\n1,3,1,0.9,1,0,0,0,0,0,3.5,0.1,0.01,nan,nan,nan,3.5\n2,6,0,0,1,0,0,0,0,0,0.15,0.15,0.02,nan,nan,nan,0\n' > "$TMP/tail/odometry_steps.csv"
check "relation_tail: the mean without the largest" 0 "^without_largest_1_m=0.2 " -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/tail" --top 1
check "relation_tail: the steps between the largest one's ends" 0 "^4,2,7,0,2,5,2,2,2,1:3.5$" -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/tail" --top 1
check "relation_tail: --top 0" 2 "relation_tail: --top 0: must be a whole number >= 1" -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/tail" --top 0
# scripts/lib/loop_consensus.py on a hand-made run: a chain of five 1 m steps along x; the gate
# refused 0 -> 3 and 1 -> 4, both at 1 m (they agree: the chain between their ends is 1 m on each
# side) and 0 -> 4 at 5 m (agrees with neither); 2 -> 5 at 3 m was applied.
mkdir -p "$TMP/consensus"
{ echo 'index,stamp,x,y,theta'; for i in 0 1 2 3 4 5; do echo "$i,$i,$i,0,0"; done; } > "$TMP/consensus/trajectory.csv"
{ echo 'keyframe,scan_index,matched,overlap_share,dx,dy,dtheta,error_x,error_y,error_theta,sigma_x,sigma_y,sigma_theta,wheel_dx,wheel_dy,wheel_dtheta,ambiguous_shift_m'
  for i in 1 2 3 4 5; do echo "$i,$i,1,0.9,1,0,0,0,0,0,0.01,0.01,0.001,nan,nan,nan,0"; done; } > "$TMP/consensus/odometry_steps.csv"
printf '%s\n' 'a,b,accepted,score,inlier_share,x,y,theta,innovation_chi2,reason' '0,3,0,0.7,0.95,1,0,0,40,"backend: innovation chi2 40 above 16.27"' \
  '1,4,0,0.7,0.95,1,0,0,41,"backend: innovation chi2 41 above 16.27"' '0,4,0,0.7,0.95,5,0,0,42,"backend: innovation chi2 42 above 16.27"' \
  '2,5,1,0.7,0.95,3,0,0,1.5,""' '1,5,0,0.6,0.5,,,,,"validation: inlier share 0.5 below 0.9"' > "$TMP/consensus/loops.csv"
check "loop_consensus: two refused loops that agree" 0 "^0,3,0,3,40,-,-,1,0$" -- /usr/bin/python3 "$REPO/scripts/lib/loop_consensus.py" "$TMP/consensus"
check "loop_consensus: one that agrees with none" 0 "^0,4,0,4,42,-,-,0,0$" -- /usr/bin/python3 "$REPO/scripts/lib/loop_consensus.py" "$TMP/consensus"
# Truth with the keyframes 1/3 m apart: 0 -> 3 and 1 -> 4 are true, 0 -> 4 (5 m for 4/3) false.
{ echo 'index,stamp,x,y,theta'; for i in 0 1 2 3 4 5; do echo "$i,$i,$(awk -v i=$i 'BEGIN { print i / 3 }'),0,0"; done; } > "$TMP/consensus/truth.csv"
check "loop_consensus: judged by the truth" 0 "^refused_false=1 mean_consistent_refused_partners_false=0$" -- /usr/bin/python3 "$REPO/scripts/lib/loop_consensus.py" "$TMP/consensus"
check "loop_consensus: --near 0" 2 "loop_consensus: --near 0: must be a number > 0" -- /usr/bin/python3 "$REPO/scripts/lib/loop_consensus.py" "$TMP/consensus" --near 0
head -1 "$TMP/consensus/loops.csv" | cut -d, -f1-5,10 > "$TMP/consensus/old_loops.csv"
check "loop_consensus: loops.csv of an older llc" 1 "loop_consensus: .*no innovation_chi2 column" -- bash -c "cp '$TMP/consensus/old_loops.csv' '$TMP/consensus/loops.csv' && printf '0,3,0,0.7,0.95,\"x\"\n' >> '$TMP/consensus/loops.csv' && /usr/bin/python3 '$REPO/scripts/lib/loop_consensus.py' '$TMP/consensus'"
sed -i 's/^4,2,7,2,7,5.0,/4,2,7,2,7,nan,/' "$TMP/tail/relation_errors.csv"
check "relation_tail: an error of nan" 1 "relation_tail: .*relation 4: translation_m is not finite" -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/tail"
check "relation_tail: a run without relation_errors.csv" 1 "relation_tail: .*relation_errors.csv" -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/slam_truth"
check "slam --truth: a missing reference, before the run" 1 "--truth: .*none.log" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_truth2" --truth "$TMP/none.log"
printf 'FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 1.0 host 1.0\nFLASER 3 1.5 2.5 3.5 1 0 0 1 0 0 2.0 host 2.0\n' > "$TMP/elsewhere.log"
check "slam --truth: a log of another drive" 1 "reference truth: 0 scan\(s\) of .*elsewhere.log" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_truth2" --truth "$TMP/elsewhere.log" --quiet
check "slam: --wrong-loop-deg 0" 2 "wrong-loop-m and --wrong-loop-deg must be > 0" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_truth2" --wrong-loop-deg 0
check "slam --drift: unknown preset" 2 "--drift must be 'moderate' or 'strong'" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_drift2" --drift wild
check "slam --drift: negative noise" 2 "noises must not be negative" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_drift2" --drift-noise-m -1
printf 'place_gate:\n  radius: -1\n' > "$TMP/bad_gate.yaml"
{ cat "$REPO/config/classifier.yaml"; echo "version: 1"; } > "$TMP/model_twice.yaml"
check "slam: a model with a key written twice" 1 "model_twice.yaml.*key 'version' is repeated" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --model "$TMP/model_twice.yaml"
printf 'odometry:\n  keyframe_distance: 0.5\n  keyframe_distance: 2.0\n' > "$TMP/twice.yaml"
check "slam: a config with a key written twice" 1 "twice.yaml: line 3: key 'keyframe_distance' is repeated" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --config "$TMP/twice.yaml"
check "slam: a negative place radius" 1 "place_gate: radius must be > 0 m" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --config "$TMP/bad_gate.yaml"
check "slam: --odometry-time-offset out of range" 2 "odometry-time-offset must be in \[-1, 1\] s" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --odometry-time-offset 2
check "slam: --odometry-time-offset on a log" 2 "odometry-time-offset is for a bag" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam3" --odometry-time-offset -0.1
check "slam: --estimate-odometry-time-offset on a log" 2 "estimate-odometry-time-offset is for a bag" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam3" --estimate-odometry-time-offset true
check "slam: --estimate-odometry-time-offset not a boolean" 2 "estimate-odometry-time-offset must be true or false" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --estimate-odometry-time-offset yes
# sim.bag's odometry is in step with its scans: the estimate keeps 0 (or has not chosen yet).
check "slam on sim.bag: the odometry time offset estimated" 0 "^odometry_time_offset=0 " -- cat "$TMP/slam/report.txt"
check "slam: --seq-reorder-scans negative" 2 "seq_reorder_scans must be 0" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --no-wheel-odometry --seq-reorder-scans -1
check "slam: --seq-reorder-scans on a log" 2 "seq-reorder-scans is for a bag" -- "$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam3" --seq-reorder-scans 5
check "slam without wheel odometry" 0 "^odometry_steps_from_wheels=0$" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam2" --quiet --no-wheel-odometry
check "slam on sim.bag: without wheels, no estimate lines" 1 "" -- grep -q "^odometry_time_offset" "$TMP/slam2/report.txt"
check "slam: the saved session maps a second run as a new chain" 0 "restored [0-9]+ keyframes .*a new chain" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam_again" --quiet --load-session "$TMP/sim.llcsession"
check "slam: the second run is joined to the first by loops" 0 "^ok$" -- awk -F= -v first="$(awk -F, '$3 == 1' "$TMP/slam/loops.csv" | wc -l)" '
    /^loops_accepted=/ {n = $2} END {print (n > 2 * first ? "ok" : "not ok: " n " loops, the first run " first)}' "$TMP/slam_again/report.txt"
check "slam: corrupt session" 1 "bad.yaml: not a laser_loop_closure session" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --load-session "$TMP/bad.yaml"
head -c 5000 "$TMP/sim.llcsession" > "$TMP/truncated.llcsession"
check "slam: truncated session" 1 "truncated session" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --load-session "$TMP/truncated.llcsession"
# llc slam with several robots: the drive cut in two, each half its own drifting odometry in a
# frame of its own; the second joins the first's map, with no wrong loop.
check "slam, several robots: --split needs one input" 2 "give exactly one --log or --bag" -- "$LLC" slam --log "$TMP/sim/sim.log" --log "$TMP/sim/sim.log" --split 2 --out "$TMP/robots0"
check "slam, several robots: a saved map that is not there" 1 "robots.llcsession: no such file" -- "$LLC" slam --log "$TMP/sim/sim.log" --split 2 --load-session "$TMP/robots.llcsession" --out "$TMP/robots0"
check "slam, several robots: a bad multi_robot parameter" 2 "cross_candidates" -- "$LLC" slam --log "$TMP/sim/sim.log" --split 2 --multi_robot/cross_candidates 0 --out "$TMP/robots0"
check "slam, several robots: a missing input" 1 "no such file" -- "$LLC" slam --log "$TMP/sim/sim.log" --log "$TMP/none.log" --out "$TMP/robots0"
check "slam, several robots: joined, never wrong" 0 "^ok$" -- bash -c "'$LLC' slam --log '$TMP/sim/sim.log' --split 2 --drift moderate --out '$TMP/robots' --save-session '$TMP/robots.llcsession' --quiet | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"robots\"] == 2 && v[\"robots_joined\"] == 2 && v[\"wrong_loops_accepted\"] == 0 && v[\"cross_robot_loops\"] >= 3 && v[\"rms_error_m\"] < 0.2 ? \"ok\" : \"not ok\")}'"
check "slam, several robots: the shared path to the join is part of the path to it" 0 "^ok$" -- awk -F'[= ]' '{v[$1] = $2}
    END { joined = v["robot_1_first_overlap_m"] + v["robot_1_joined_after_overlap_m"]; s = v["robot_1_shared_path_to_join_m"]
          print (s != "" && s >= 0 && s <= joined + 1e-6 && v["robot_1_first_overlap_m"] >= 0 ? "ok" : "not ok: shared " s " of " joined) }' "$TMP/robots/report.txt"
check "slam, several robots: trajectory.csv has a robot column, every keyframe joined" 0 "^ok$" -- awk -F, 'NR == 1 { if ($0 != "robot,index,stamp,x,y,theta,joined") bad++; next }
    { n[$1]++; if ($7 != 1) bad++ } END { print (!bad && n[0] > 50 && n[1] > 50 ? "ok" : "not ok") }' "$TMP/robots/trajectory.csv"
check "slam, several robots: their session is a map llc localize finds itself on" 0 "^ok$" -- bash -c "'$LLC' localize --session '$TMP/robots.llcsession' --log '$TMP/sim/sim.log' --drift moderate --truth '$TMP/sim/sim.log' --start-scan 100 --end-scan 400 --out '$TMP/robots_loc' | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"fixes\"] >= 1 && v[\"wrong_fixes\"] == 0 ? \"ok\" : \"not ok\")}'"

# llc localize: the drive's log mapped, then found on that map from anywhere with drifted odometry.
check "localize: --session is required" 2 "--session" -- "$LLC" localize --log "$TMP/sim/sim.log" --out "$TMP/loc0"
check "localize: corrupt session" 1 "bad.yaml: not a laser_loop_closure session" -- "$LLC" localize --session "$TMP/bad.yaml" --log "$TMP/sim/sim.log" --out "$TMP/loc0"
check "localize: truncated session" 1 "truncated session" -- "$LLC" localize --session "$TMP/truncated.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0"
check "localize: a kidnapping needs both ends" 2 "both --kidnap-at SCAN and --kidnap-to SCAN" -- "$LLC" localize --session "$TMP/sim.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --kidnap-at 5
check "localize: --starts needs --truth" 2 "--starts needs --truth" -- "$LLC" localize --session "$TMP/sim.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --starts 3
check "localize: --seen-heading-deg outside (0, 180], refused before anything is read" 2 "seen-heading-deg must be in \(0, 180\]" -- "$LLC" localize --session "$TMP/no_such.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --seen-heading-deg 0
check "localize: --starts 0 refused before anything is read" 2 "must be > 0" -- "$LLC" localize --session "$TMP/no_such.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --starts 0
check "localize: --start-scan beyond the input" 2 "start-scan must be before" -- "$LLC" localize --session "$TMP/sim.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --start-scan 99999
check "localize: a bad localization parameter" 2 "min_track_fit" -- "$LLC" localize --session "$TMP/sim.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --localization/min_track_fit 0
"$LLC" slam --log "$TMP/sim/sim.log" --out "$TMP/slam_log" --quiet --save-session "$TMP/sim_log.llcsession" >/dev/null 2>&1
"$LLC" simulate --out "$TMP/sim_other" --length-m 300 --seed 7 >/dev/null 2>&1
check "localize --truth: another recording than the session's is refused" 1 "only [0-9]+ of the session's [0-9]+ keyframes" -- "$LLC" localize --session "$TMP/sim_log.llcsession" --log "$TMP/sim/sim.log" --truth "$TMP/sim_other/sim.log" --out "$TMP/loc0"
check "localize: fixed, never wrong" 0 "^wrong_fixes=0 " -- "$LLC" localize --session "$TMP/sim_log.llcsession" --log "$TMP/sim/sim.log" --drift moderate --truth "$TMP/sim/sim.log" --start-scan 100 --end-scan 400 --out "$TMP/loc"
check "localize: poses.csv, a row per scan from the start, nan while lost" 0 "^ok$" -- awk -F, '
    NR == 1 { if ($0 != "scan,stamp,x,y,theta,state") bad++; next }
    { n++; if ($1 != 99 + n) bad++; if ($6 == "lost") { lost++; if ($3 != "nan") bad++ } else if ($6 == "localized") { loc++; if ($3 == "nan") bad++ } else bad++ }
    END { print (!bad && n == 300 && loc > 150 ? "ok" : "not ok: " n " rows, " loc " localized, " bad " bad") }' "$TMP/loc/poses.csv"
check "localize: the report" 0 "^ok$" -- awk -F'[= ]' '{v[$1] = $2} END {
    print (v["first_fix_scan"] >= 100 && v["first_fix_travel_m"] < 30 && v["fixes"] >= 1 && v["rms_error_localized_m"] < 0.2 && v["wrong_poses"] == 0 ? "ok" : "not ok") }' "$TMP/loc/report.txt"
check "localize: every localized scan is judged or counted beyond the map" 0 "^ok$" -- bash -c "n=\$(awk -F, '\$6 == \"localized\"' '$TMP/loc/poses.csv' | wc -l); awk -F'[= ]' -v n=\$n '{v[\$1] = \$2} END {print (v[\"localized_scans\"] + v[\"beyond_map_poses\"] == n && n > 0 ? \"ok\" : \"not ok\")}' '$TMP/loc/report.txt'"
# A reference glitch (scans 200-202's true headings turned by 0.19 rad in a copy, as csail's
# corrected log has at 397-399): the poses there are judged wrong, and every one of them is
# found judged by a reference its own scans contradict.
awk '$1 == "TRUEPOS" { if (n >= 200 && n <= 202) $4 = $4 + 0.19; n++ } { print }' "$TMP/sim/sim.log" > "$TMP/sim_glitch.log"
check "localize: wrong only by a glitch of the reference, and found so" 0 "^ok$" -- bash -c "'$LLC' localize --session '$TMP/sim_log.llcsession' --log '$TMP/sim_glitch.log' --drift moderate --truth '$TMP/sim/sim.log' --start-scan 100 --end-scan 400 --out '$TMP/loc_glitch' | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"wrong_poses\"] >= 2 && v[\"wrong_poses_truth_contradicted\"] == v[\"wrong_poses\"] ? \"ok\" : \"not ok: \" v[\"wrong_poses_truth_contradicted\"] \" of \" v[\"wrong_poses\"])}'"
check "localize --judge-within-m 1e9: no pose beyond the map" 0 "^beyond_map_poses=0 " -- "$LLC" localize --session "$TMP/sim_log.llcsession" --log "$TMP/sim/sim.log" --drift moderate --truth "$TMP/sim/sim.log" --start-scan 100 --end-scan 400 --out "$TMP/loc_judge" --judge-within-m 1e9
check "localize: --judge-within-m 0 refused before anything is read" 2 "judge-within-m must be > 0" -- "$LLC" localize --session "$TMP/no_such.llcsession" --log "$TMP/sim/sim.log" --out "$TMP/loc0" --judge-within-m 0
check "localize: search.csv" 0 "^scan,path_m,candidates,loops,agreeing_keyframes,rival_keyframes,joined,recent_fit,why_not$" -- head -1 "$TMP/loc/search.csv"
check "localize: candidates.csv, each search's candidates; every accepted one a reason-free row, the map's place for some" 0 "^ok$" -- awk -F, '
    NR == 1 { if ($0 != "scan,map_keyframe,score,accepted,inlier_share,x,y,theta,error_m,error_deg,why_not") bad++; next }
    { n++; if ($4 == 1) { acc++; if ($11 != "\"\"") bad++; if ($9 < 0.3) right++ } else if ($11 == "\"\"") bad++ }
    END { print (!bad && n > 0 && right > 0 ? "ok" : "not ok: " n " rows, " acc " accepted, " right " right, " bad " bad") }' "$TMP/loc/candidates.csv"
check "localize: kidnapped, noticed within 2 s, never wrong after" 0 "^ok$" -- bash -c "'$LLC' localize --session '$TMP/sim_log.llcsession' --log '$TMP/sim/sim.log' --truth '$TMP/sim/sim.log' --start-scan 100 --kidnap-at 300 --kidnap-to 600 --end-scan 800 --out '$TMP/loc_kidnap' | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"kidnap_lost_after_s\"] >= 0 && v[\"kidnap_lost_after_s\"] <= 2 && v[\"wrong_poses_after_kidnap_lost\"] == 0 && v[\"relocalizations\"] >= 1 ? \"ok\" : \"not ok: lost after \" v[\"kidnap_lost_after_s\"] \" s\")}'"
check "localize --starts: starts.csv and the summary" 0 "^ok$" -- bash -c "'$LLC' localize --session '$TMP/sim_log.llcsession' --log '$TMP/sim/sim.log' --drift moderate --truth '$TMP/sim/sim.log' --starts 3 --start-travel 30 --out '$TMP/loc_starts' | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"starts\"] == 3 && v[\"wrong_fixes\"] == 0 && v[\"fixed_share\"] == 1 ? \"ok\" : \"not ok\")}' && test \$(wc -l < '$TMP/loc_starts/starts.csv') -eq 4"
check "localize --starts: a start needs --fix-within-m of the drive after it (a 600 m drive has none 1 km from its end)" 1 "with --fix-within-m of path after it" -- "$LLC" localize --session "$TMP/sim_log.llcsession" --log "$TMP/sim/sim.log" --truth "$TMP/sim/sim.log" --starts 3 --fix-within-m 1000 --out "$TMP/loc_starts_far"
check "slam: no input" 2 "give --bag BAG or --log LOG" -- "$LLC" slam --out "$TMP/slam3"
check "slam: a bag and a log are two robots, each read" 1 "no such file" -- "$LLC" slam --bag "$TMP/none.bag" --log "$TMP/sim/sim.log" --out "$TMP/slam3"
slam_keyframes="$(sed -n 's/^keyframes=//p' "$TMP/slam/report.txt")"
check "slam: a pipeline parameter as a flag (--odometry/keyframe_distance 3: fewer keyframes)" 0 "^ok$" -- bash -c "'$LLC' slam --bag '$TMP/sim/sim.bag' --out '$TMP/slam_flag' --quiet --odometry/keyframe_distance 3 >/dev/null && awk -F= -v before='$slam_keyframes' '/^keyframes=/ {print (\$2 + 0 < before / 2 ? \"ok\" : \"not ok: \" \$2 \" of \" before)}' '$TMP/slam_flag/report.txt'"
check "slam: a bad parameter flag is refused before the run" 2 "parameter 'odometry/keyframe_distance': bad value" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam_badflag" --odometry/keyframe_distance far
check "slam: ... and left no output folder" 0 "^absent$" -- bash -c "test -e '$TMP/slam_badflag' && echo present || echo absent"
check "slam: an unknown parameter flag" 2 "unknown option --odometry/keyframe_distanse" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --odometry/keyframe_distanse 1
check "slam --help lists every pipeline parameter with its default and meaning" 0 "^  --aligner/icp/trim_fraction 0\.9   # share of the nearest pairs" -- "$LLC" slam --help
printf 'odometry:\n  keyframe_distanse: 2\n' > "$TMP/bad_slam.yaml"
check "slam: unknown parameter" 1 "unknown parameter 'odometry/keyframe_distanse'" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --config "$TMP/bad_slam.yaml"
check "slam: corrupt model" 1 "bad.yaml" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam3" --model "$TMP/bad.yaml"
check "pairs on sim.log (360 degrees)" 0 "any heading" -- "$LLC" pairs --log "$TMP/sim/sim.log" --out "$TMP/sim/pairs.csv"
head -c 8 "$TMP/sim/world.png" | od -c | grep -q "P   N   G" && passed=$((passed + 1)) || { failed=$((failed + 1)); echo "FAIL: world.png is no PNG"; }
# Every log-taking subcommand also takes the bag, with topic flags.
check "pairs on sim.bag" 0 "any heading" -- "$LLC" pairs --log "$TMP/sim/sim.bag" --out "$TMP/sim/bag_pairs.csv" --max-per-class 60
check "features on sim.bag" 0 "features=157" -- "$LLC" features --log "$TMP/sim/sim.bag" --out "$TMP/sim/f.csv"
printf '1 2 0 0 0 0 0 0\n' > "$TMP/one.relations"
printf 'scan,stamp,x,y,theta,keyframe\n0,1.0,0,0,0,0\n1,1.1,nan,0,0,0\n' > "$TMP/nan_scans.csv"
check "relations: a pose that is not finite, by line" 1 "nan_scans.csv:3: expected 6 comma-separated values with a finite pose" -- "$LLC" relations --log "$TMP/sim/sim.log" --poses "$TMP/nan_scans.csv" --relations "$TMP/one.relations"
printf 'scan,stamp,x,y,theta,keyframe\nfirst,1.0,0,0,0,0\n' > "$TMP/word_scans.csv"
check "relations: a scan index that is a word" 1 "word_scans.csv:2: 'first' is not a scan index" -- "$LLC" relations --log "$TMP/sim/sim.log" --poses "$TMP/word_scans.csv" --relations "$TMP/one.relations"
printf 'stamp,x,y\n1.0,0,0\n' > "$TMP/no_theta.csv"
check "relations: keyframes without a heading column" 1 "no_theta.csv:1: no column theta" -- "$LLC" relations --log "$TMP/sim/sim.log" --keyframes "$TMP/no_theta.csv" --relations "$TMP/one.relations"
check "train on sim.bag" 0 "rounds=20" -- "$LLC" train --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --model "$TMP/sim/m.yaml" --rounds 20 --repeats 1
check "score on sim.bag" 0 "pairs=120" -- "$LLC" score --model "$TMP/sim/m.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/s.csv"
check "evaluate on sim.bag" 0 "^auc=" -- "$LLC" evaluate --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/ev" --repeats 1 --no-curve --no-ablation
# Augmented training: the model records it; a bad list, two kinds to score by, --augment
# outside leave-one-log-out are refused before anything is loaded.
check "train --augment: the model records the kinds and the rows they added" 0 "^ok$" -- bash -c "'$LLC' train --data '$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv' --model '$TMP/sim/aug.yaml' --rounds 20 --repeats 1 --augment half-beams,double-beams >/dev/null && grep -q 'augment: half-beams,double-beams' '$TMP/sim/aug.yaml' && grep -q 'augmented_rows: 240' '$TMP/sim/aug.yaml' && echo ok"
check "score --augment half-beams" 0 "pairs=120" -- "$LLC" score --model "$TMP/sim/m.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/s_half.csv" --augment half-beams
check "score --augment: the scores differ from the native ones" 0 "^ok$" -- bash -c "cmp -s '$TMP/sim/s.csv' '$TMP/sim/s_half.csv' || echo ok"
check "train --exclude-features: the model's most used feature is then no stump's" 0 "^ok$" -- bash -c "f=\$(grep -o 'feature: [0-9]*, name: [a-z0-9_]*' '$TMP/sim/m.yaml' | awk '{print \$4}' | sort | uniq -c | sort -rn | awk 'NR == 1 {print \$2}'); test -n \"\$f\" && '$LLC' train --data '$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv' --model '$TMP/sim/ex.yaml' --rounds 20 --repeats 1 --exclude-features \$f >/dev/null && grep -q \"excluded_features: \$f\" '$TMP/sim/ex.yaml' && ! grep -q \"name: \$f,\" '$TMP/sim/ex.yaml' && echo ok"
check "train --exclude-features: an unknown name" 2 "no pair feature 'bogus' in the extended set" -- "$LLC" train --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --model "$TMP/sim/ex2.yaml" --exclude-features size,bogus
check "train --augment: an unknown kind" 2 "--augment: unknown augmentation 'quarter-beams'" -- "$LLC" train --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --model "$TMP/sim/aug2.yaml" --augment half-beams,quarter-beams
check "train --augment: a kind twice" 2 "given twice" -- "$LLC" train --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --model "$TMP/sim/aug2.yaml" --augment half-beams,half-beams
check "features --augment half-beams: the stamps stay, the points (size) halve" 0 "^ok$" -- bash -c "'$LLC' features --log '$TMP/sim/sim.log' --out '$TMP/sim/f_full.csv' >/dev/null && '$LLC' features --log '$TMP/sim/sim.log' --out '$TMP/sim/f_half.csv' --augment half-beams >/dev/null && paste -d, '$TMP/sim/f_full.csv' '$TMP/sim/f_half.csv' | awk -F, 'NR == 1 {n = NF / 2; for (i = 1; i <= n; i++) if (\$i == \"size\") c = i; next} {r = \$(n + c) / \$c; if (\$2 != \$(n + 2) || r < 0.4 || r > 0.6) bad++} END {print (c && NR > 100 && !bad ? \"ok\" : \"not ok\")}'"
check "score --augment: two kinds" 2 "takes one kind" -- "$LLC" score --model "$TMP/sim/m.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/s2.csv" --augment half-beams,double-beams
check "evaluate --augment without --leave-one-log-out" 2 "go with --leave-one-log-out" -- "$LLC" evaluate --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/ev2" --augment half-beams
# Alignment: CRF-match + ICP + shape validation against the drive's ground truth, PCL beside it.
check "align on sim.bag" 0 "pcl_gicp_identity: within_tolerance=" -- "$LLC" align --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/align.csv" --compare-pcl
check "align csv header" 0 "^a,b,label,x,y,theta,inlier_share,accepted,ms$" -- head -1 "$TMP/sim/align.csv"
check "align: >= 90% of positives within 0.2 m / 2 deg" 0 "^ok$" -- bash -c "'$LLC' align --data '$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv' --out '$TMP/sim/a2.csv' | awk -F'[= ]' '/^crf_icp/ {print (\$3 >= 0.9 ? \"ok\" : \"low \" \$3)}'"
check "align --truth-check sorts the failures" 0 "^failed_positives=[0-9]+ no_start_near_truth=[0-9]+ better_fit_elsewhere=[0-9]+ truth_moves_under_icp=[0-9]+ icp_fails_at_truth=[0-9]+ of_those_two_gicp_from_truth_agrees_off_truth=[0-9]+ gicp_from_truth_stays=[0-9]+$" -- "$LLC" align --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a6.csv" --truth-check --aligner/global_search_below 1
check "align --truth-check csv header" 0 "^a,b,label,x,y,theta,inlier_share,accepted,ms,fit,truth_fit,icp_from_truth_converged,icp_from_truth_fit,icp_from_truth_error_m,icp_from_truth_error_deg,icp_from_truth_refusal,gicp_from_truth_converged,gicp_from_truth_error_m,gicp_from_truth_error_deg,error_m,error_deg$" -- head -1 "$TMP/sim/a6.csv"
check "align: global-search-below out of range" 2 "global_search_below must be in \[0, 1\]" -- "$LLC" align --aligner/global_search_below 2 --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a7.csv"
check "align: min-relative-overlap out of range" 2 "min_relative_overlap must be in \[0, 1\]" -- "$LLC" align --aligner/min_relative_overlap 2 --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a7.csv"
check "align: icp-fixed-pairs-after below 1" 2 "fixed_pairs_after must be >= 1" -- "$LLC" align --aligner/icp/fixed_pairs_after 0 --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a7.csv"
check "align with a model aligns only its matches" 0 "accepted by the classifier" -- "$LLC" align --model "$TMP/sim/m.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a3.csv"
check "train --from-session: self-labelled keyframe pairs of a mapped drive" 0 "^session .*: [0-9]+ keyframes, [1-9][0-9]* positive and [1-9][0-9]* negative pairs labelled by their optimised poses$" -- "$LLC" train --from-session "$TMP/sim.llcsession" --model "$TMP/sim/self.yaml" --rounds 20 --repeats 1
check "train --from-session beside --data" 0 "^pairs=(1[3-9][0-9]|[2-9][0-9]{2}|[0-9]{4,}) " -- "$LLC" train --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --from-session "$TMP/sim.llcsession" --model "$TMP/sim/self2.yaml" --rounds 20 --repeats 1
printf 'not a session' > "$TMP/corrupt.llcsession"
check "train --from-session refuses a corrupt session" 1 "corrupt.llcsession" -- "$LLC" train --from-session "$TMP/corrupt.llcsession" --model "$TMP/sim/self3.yaml"
# A crafted session (as anyone could write one, FNV-1a being no protection): 200 kB whose
# keyframe count says 3e7, its length and checksum made to fit. Refused before anything is
# sized by the count, within 250 MB of address space (3.3 GB before).
/usr/bin/python3 - "$TMP/sim.llcsession" "$TMP/crafted.llcsession" <<'PY'
import struct, sys
b = open(sys.argv[1], "rb").read()
body = struct.pack("<Q", 30000000) + b[32:24 + 200000]  # magic 12, version 4, length 8, then the count
h = 14695981039346656037
for c in body:
    h = ((h ^ c) * 1099511628211) & 0xffffffffffffffff
open(sys.argv[2], "wb").write(b[:16] + struct.pack("<Q", len(body)) + body + struct.pack("<Q", h))
PY
check "train --from-session: a crafted count of 3e7 keyframes, refused within a memory bound" 1 "crafted.llcsession: corrupt session \(a count of 30000000 that the [0-9]+ bytes left cannot hold" -- bash -c "ulimit -v 250000; '$LLC' train --from-session '$TMP/crafted.llcsession' --model '$TMP/sim/self4.yaml'"
check "score prints detection at 1% FA" 0 "^detection_at_1pct_fa=[0-9.]+ auc=[0-9.]+" -- "$LLC" score --model "$TMP/sim/self.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/self_scores.csv"
check "train-crf on sim.bag" 0 "positive_pairs=60" -- "$LLC" train-crf --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/crf.yaml" --epochs 2
check "align with learnt CRF weights" 0 "crf_icp: within_tolerance=" -- "$LLC" align --crf-weights "$TMP/sim/crf.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a4.csv"
check "align: corrupt CRF weights" 1 "bad.yaml: not a laser_loop_closure CRF weights file" -- "$LLC" align --crf-weights "$TMP/bad.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a5.csv"
check "align: share of accepted positives within tolerance" 0 "^accepted_positives_within_tolerance=[01]\.[0-9]+ \([0-9]+/[0-9]+\)$" -- "$LLC" align --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a7.csv"
check "align: negative position std" 2 "validation: max_position_std must be finite and >= 0" -- "$LLC" align --aligner/validation/max_position_std -1 --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a6.csv"
check "align: bad validation share" 2 "validation: min_inlier_share must be in" -- "$LLC" align --aligner/validation/min_inlier_share 2 --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a6.csv"
check "evaluate --validate" 0 "validated_detection_at_1pct_fa=" -- "$LLC" evaluate --validate --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/ev2" --repeats 1 --no-curve --no-ablation --no-rotation
check "evaluate --validate writes the validated ROC" 0 "false_alarm,detection" -- head -1 "$TMP/sim/ev2/roc_validated.csv"
# Leave-one-log-out: each log scored by a model trained on the others only.
check "evaluate --leave-one-log-out needs two logs" 2 "needs at least two --data items" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/lolo"
check "evaluate --leave-one-log-out" 0 "^mean_detection_at_1pct_fa=" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo" --rounds 10 --folds 3
check "evaluate --leave-one-log-out csv" 0 "^log,pairs,positives,training_pairs,k,detection_at_k,realised_false_alarm,false_alarm_negatives,detection_at_1pct_fa,detection_at_0pct_fa,auc,calibration_pairs,calibration_target,calibrated_k,detection_at_calibrated_k,realised_false_alarm_calibrated$" -- head -1 "$TMP/sim/lolo/leave_one_log_out.csv"
check "evaluate --leave-one-log-out: each held-out log trained on the other" 0 "^sim,120,60,[0-9]+," -- grep "^sim,120," "$TMP/sim/lolo/leave_one_log_out.csv"
check "evaluate --leave-one-log-out --augment: the summary names it, the held-out log scored on its own 120 pairs" 0 "^ok$" -- bash -c "'$LLC' evaluate --leave-one-log-out --data '$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv' --data '$TMP/sim/sim.log:$TMP/sim/pairs.csv' --out '$TMP/sim/lolo6' --rounds 10 --folds 3 --augment half-beams >/dev/null 2>&1; grep -q 'augment=half-beams' '$TMP/sim/lolo6/summary.txt' && grep -q '^sim,120,60,' '$TMP/sim/lolo6/leave_one_log_out.csv' && echo ok"
check "evaluate --leave-one-log-out --false-alarm-negatives: 60 + 500 negatives" 0 "^sim,120,60,[0-9]+,[0-9.]+,[0-9.]+,[0-9.]+,560," -- bash -c "'$LLC' evaluate --leave-one-log-out --data '$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv' --data '$TMP/sim/sim.log:$TMP/sim/pairs.csv' --out '$TMP/sim/lolo2' --rounds 10 --folds 3 --false-alarm-negatives 500 >/dev/null 2>&1; grep '^sim,120,' '$TMP/sim/lolo2/leave_one_log_out.csv'"
check "evaluate --leave-one-log-out --calibration-pairs: K fitted on 300 surely-different pairs of the drifted odometry" 0 "^sim,120,60,[0-9]+,[0-9.]+,[0-9.]+,[0-9.]+,60,[0-9.]+,[0-9.]+,[0-9.]+,300,0.015,[0-9.]+,[0-9.]+,[0-9.]+$" -- bash -c "'$LLC' evaluate --leave-one-log-out --data '$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv' --data '$TMP/sim/sim.log:$TMP/sim/pairs.csv' --out '$TMP/sim/lolo3' --rounds 10 --folds 3 --calibration-pairs 300 --drift moderate >/dev/null 2>&1; grep '^sim,120,' '$TMP/sim/lolo3/leave_one_log_out.csv'"
check "evaluate --calibration-targets needs three logs (a target chosen on others than the held-out one)" 2 "calibration-targets needs at least three --data items" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo5" --calibration-pairs 300 --calibration-targets 0.04,0.02
check "evaluate --calibration-targets refuses a rate outside (0, 1)" 2 "calibration-targets: '1.5' is not a rate" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo4" --calibration-pairs 10 --calibration-targets 0.01,1.5
check "evaluate --calibration-targets needs --calibration-pairs" 2 "calibration-targets needs --calibration-pairs" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo4" --calibration-targets 0.01
check "evaluate --leave-one-log-out --validate: the loop stage held out" 0 "^loop_stage_held_out: true_pairs_confirmed=[0-9]+/260 false_pairs_accepted=[0-9]+ \(of [0-9]+ negatives that passed K\)$" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo5" --rounds 10 --folds 3 --validate
check "evaluate --leave-one-log-out --validate writes loop_stage.csv" 0 "^log,a,b,label,extra,score,accepted,inlier_share,seen_through_share,position_std,true_distance_m,error_m,error_deg,gate_chi2,through_gate,reject_reason$" -- head -1 "$TMP/sim/lolo5/loop_stage.csv"
check "evaluate --leave-one-log-out --validate without --drift says the gate needs it" 0 "^loop_stage_with_gate: not run" -- cat "$TMP/sim/lolo5/summary.txt"
check "evaluate --leave-one-log-out --validate --drift: the back end's gate too" 0 "^loop_stage_with_gate: true_pairs_through=[0-9]+/260 false_pairs_through=[0-9]+ wrong_poses_through=[0-9]+ " -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo6" --rounds 10 --folds 3 --validate --drift moderate
check "evaluate --loops/calibration/max_path must be positive" 2 "max_path must be finite and > 0" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo4" --calibration-pairs 10 --loops/calibration/max_path -5
check "evaluate --calibration-pairs must not be negative" 2 "calibration-pairs must be zero or more" -- "$LLC" evaluate --leave-one-log-out --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --data "$TMP/sim/sim.log:$TMP/sim/pairs.csv" --out "$TMP/sim/lolo4" --calibration-pairs -1
# Pose graphs through the ESDF: a small g2o file written here (a square with one loop edge).
printf 'EDGE_SE2 0 1 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 1 2 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 2 3 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 3 0 1.05 0 1.5707963 100 0 0 100 0 400\n' > "$TMP/square.g2o"
check "graph incremental" 0 "^seconds=" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/square_out.g2o"
# Per-step latency: one step per edge (4 on the square), ordered percentiles, the worst step named.
check "graph incremental: step latencies, ordered, the worst step named" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/square_out.g2o' | awk -F= '{v[\$1] = \$2} END {print (v[\"step_latency_median_ms\"] != \"\" && v[\"step_latency_median_ms\"] <= v[\"step_latency_p90_ms\"] && v[\"step_latency_p90_ms\"] <= v[\"step_latency_p99_ms\"] && v[\"step_latency_p99_ms\"] <= v[\"step_latency_max_ms\"] && v[\"step_latency_max_at\"] >= 0 && v[\"step_latency_max_at\"] < 4 && v[\"total_seconds\"] > 0 ? \"ok\" : \"not ok\")}'"
check "graph: the peak memory, in all and per pose" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/square_m.g2o' | awk -F= '{v[\$1] = \$2} END {print (v[\"peak_rss_mb\"] > 0 && v[\"peak_rss_bytes_per_pose\"] > 0 && v[\"peak_rss_bytes_per_pose\"] * 4 / 1048576 > 0.99 * v[\"peak_rss_mb\"] && v[\"peak_rss_bytes_per_pose\"] * 4 / 1048576 < 1.01 * v[\"peak_rss_mb\"] ? \"ok\" : \"not ok\")}'"
check "graph --latency-csv: a header and one row per edge of the file, in order, none negative" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/square_l.g2o' --latency-csv '$TMP/steps.csv' >/dev/null && awk -F, 'NR == 1 {ok = (\$0 == \"step,edge_from,edge_to,ms\")} NR > 1 {ok = ok && \$1 == NR - 2 && \$4 >= 0} END {print (ok && NR - 1 == '\$(grep -c ^EDGE_SE2 '$TMP/square.g2o')' ? \"ok\" : \"not ok\")}' '$TMP/steps.csv'"
check "graph --latency-csv with --batch: refused (a batch run has no steps)" 2 "not --batch" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --batch --latency-csv "$TMP/steps_b.csv"
check "graph --latency-csv into a folder that does not exist: refused before the run" 1 "latency-csv" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --latency-csv "$TMP/no/such/dir/steps.csv"
check "graph batch: no step latencies" 1 "" -- bash -c "'$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/square_b2.g2o' --batch | grep -q step_latency"
check "graph: output has every vertex and edge" 0 "^8$" -- bash -c "grep -c _SE2 '$TMP/square_out.g2o'"
check "graph batch" 0 "^chi2=0\\.0" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/square_b.g2o" --batch
# The same square with its chain's second half first (two sessions joined later, as ais2klinik):
# each waiting edge augments its pose once the one before exists, to the same optimum.
printf 'EDGE_SE2 0 1 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 2 3 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 3 0 1.05 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 1 2 1 0 1.5707963 100 0 0 100 0 400\n' > "$TMP/square_late.g2o"
check "graph incremental: a chain that arrives before the edge reaching it" 0 "^same$" -- bash -c "a=\$('$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/x1.g2o' | grep '^chi2='); b=\$('$LLC' graph --g2o '$TMP/square_late.g2o' --out '$TMP/x2.g2o' | grep '^chi2='); [ -n \"\$a\" ] && [ \"\$a\" = \"\$b\" ] && echo same"
check "graph: both modes" 2 "exclude each other" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --batch --incremental
# An edge id far beyond what the file's edges can chain: refused before anything is sized by it,
# within 250 MB of address space (llc starts within 125 MB; 4e8 once took 12.5 GB for 36 s).
printf 'EDGE_SE2 0 400000000 1 0 0 1 0 0 1 0 1\n' > "$TMP/huge_id.g2o"
check "graph: a huge edge id, refused within a memory bound" 1 "cannot be whole" -- bash -c "ulimit -v 250000; '$LLC' graph --g2o '$TMP/huge_id.g2o' --out '$TMP/x.g2o'"
# Damaged bags within the same bound: three bytes inserted mid-file (rosbag reserved what the
# shifted lengths claimed: 0.7-1.7 GB, and under a memory bound died on an assertion), and one
# scan's ranges length set to 4.3e8 (roscpp's deserializer took 1.7 GB): the first refused with
# the byte named, the second left out with a warning and the rest read.
/usr/bin/python3 - "$TMP/sim/sim.bag" "$TMP" <<'PY'
import struct, sys
bag, tmp = sys.argv[1], sys.argv[2]
b = open(bag, "rb").read()
open(tmp + "/inserted.bag", "wb").write(b[:len(b) // 2] + b"\x01\x02\x03" + b[len(b) // 2:])
m = bytearray(b)
start = found = 0
while found < 6:  # the sixth front scan: frame_id, seven float32, then the ranges' length
    at = m.index(b"laser_front", start) + 11 + 28
    start = at - 28
    if struct.unpack("<I", m[at:at + 4])[0] == 361:
        found += 1
m[at:at + 4] = struct.pack("<I", 430000000)
open(tmp + "/long_ranges.bag", "wb").write(bytes(m))
PY
check "a bag with bytes inserted: refused within a memory bound, the byte named" 1 "inserted.bag: not a readable bag \(.* at byte [0-9]+\)" -- bash -c "ulimit -v 250000; '$LLC' pairs --log '$TMP/inserted.bag' --out '$TMP/x.csv'"
check "a bag scan whose ranges length claims 1.7 GB: left out within the bound, the rest read" 0 "left out 1 damaged messages; the first: a sensor_msgs/LaserScan on /scan_front" -- bash -c "ulimit -v 250000; '$LLC' pairs --log '$TMP/long_ranges.bag' --out '$TMP/x.csv'"
printf 'EDGE_SE2 0 1 1 0 0 1 0 0 1 0 15xyz\n' > "$TMP/junk.g2o"
check "graph: a number with trailing text, the line named" 1 "junk.g2o:1: EDGE_SE2: unexpected text 'xyz'" -- "$LLC" graph --g2o "$TMP/junk.g2o" --out "$TMP/x.g2o"
check "graph: negative relinearize-chi2" 2 "relinearize_chi2 must be finite and >= 0" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --esdf/relinearize_chi2 -1
printf 'VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1\n' > "$TMP/bad.g2o"
check "graph: negative max-edges-in-place" 2 "max_edges_relinearized_in_place must be >= 0" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --esdf/max_edges_relinearized_in_place -1
check "graph: reorder-fill-ratio below 1" 2 "reorder_fill_ratio must be finite and >= 1" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --esdf/reorder_fill_ratio 0.5
check "graph: every swap as a rebuild still reaches the optimum" 0 "^chi2=0\\.0" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --esdf/max_edges_relinearized_in_place 0
check "graph: prints where its time went" 0 " seconds_rank_updates=[0-9.e+-]+ seconds_solves=[0-9.e+-]+ seconds_factorizations=[0-9.e+-]+ " -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o"
check "graph: prints its rebuild count" 0 " rebuilds=[0-9]+ " -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o"
printf 'EDGE_SE2 0 1 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 1 2 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 2 3 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 3 0 1.05 0 1.5707963 1e24 0 0 1e24 0 1e24\n' > "$TMP/too_sure.g2o"
check "graph: a loop beyond max_information is refused" 0 "refused edge 3 -> 0: information .* above max_information" -- "$LLC" graph --g2o "$TMP/too_sure.g2o" --out "$TMP/x.g2o"
check "graph: max-information is an option" 0 "refused=0" -- "$LLC" graph --g2o "$TMP/too_sure.g2o" --out "$TMP/x.g2o" --esdf/max_information 1e25
check "graph: max-information must be positive" 2 "max_information must be finite and > 0" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --esdf/max_information 0
# A wrong loop (pose 3 said to be 1 m from pose 0, in a 4 m square walked twice) bends the
# least-squares solution; robust loops hold it at the clean optimum.
printf 'EDGE_SE2 0 1 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 1 2 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 2 3 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 3 4 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 4 5 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 5 6 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 6 7 1 0 1.5707963 100 0 0 100 0 400\nEDGE_SE2 0 4 0 0 0 100 0 0 100 0 400\nEDGE_SE2 1 5 0 0 0 100 0 0 100 0 400\nEDGE_SE2 2 6 0 0 0 100 0 0 100 0 400\nEDGE_SE2 3 7 0 0 0 100 0 0 100 0 400\nEDGE_SE2 0 6 3 3 1 100 0 0 100 0 400\n' > "$TMP/wrong_loop.g2o"
check "graph --least-squares: a wrong loop bends least squares" 0 "^chi2=[0-9]{3,}" -- "$LLC" graph --g2o "$TMP/wrong_loop.g2o" --out "$TMP/x.g2o" --least-squares
check "graph --least-squares: the misfitting constraints counted, nothing re-solved" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/wrong_loop.g2o' --out '$TMP/x.g2o' --least-squares | awk -F= '/^misfit_constraints=/ {m = \$2} /^robust:/ {r = 1} END {print (m >= 1 && !r ? \"ok\" : \"not ok\")}'"
check "graph, defaults: the wrong loop held at no weight by the re-solve" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/wrong_loop.g2o' --out '$TMP/x.g2o' | awk '/^robust: loops_down_weighted=1 .*re-solve from the start kept/ {r = 1; split(\$3, c, \"=\"); cost = c[2] + 0} END {print (r && cost < 16.27 * 1.01 ? \"ok\" : \"not ok: \" cost)}'"
check "graph --batch, defaults: the wrong loop held at no weight" 0 "^robust: loops_down_weighted=1 " -- "$LLC" graph --g2o "$TMP/wrong_loop.g2o" --out "$TMP/x.g2o" --batch
check "graph, defaults: a graph whose loops fit ends at its least-squares optimum, no loop let go" 0 "^ok$" -- bash -c "ls=\$('$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/x.g2o' --least-squares | sed -n 's/^chi2=//p'); '$LLC' graph --g2o '$TMP/square.g2o' --out '$TMP/x.g2o' | awk -v ls=\"\$ls\" '/^misfit_constraints=0$/ {m = 1} /^robust: loops_down_weighted=0 / {r = 1} /^chi2=/ {sub(/^chi2=/, \"\"); c = \$1 + 0} END {print (m && r && ls > 0 && c <= ls * (1 + 1e-9) && c >= 0.999 * ls ? \"ok\" : \"not ok: \" c \" against \" ls)}'"
check "graph --esdf/robust_loop_chi2: the wrong loop held at no weight" 0 "^robust: loops_down_weighted=1 " -- "$LLC" graph --g2o "$TMP/wrong_loop.g2o" --out "$TMP/x.g2o" --esdf/robust_loop_chi2 16.27
check "graph --esdf/robust_loop_chi2 --batch: the rest fits exactly" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$TMP/wrong_loop.g2o' --out '$TMP/x.g2o' --esdf/robust_loop_chi2 16.27 --batch | awk '/^robust:/ {split(\$3, c, \"=\"); print (c[2] < 16.27 * 1.01 ? \"ok\" : \"robust cost \" c[2])}'"
check "graph: robust-loop-chi2 must not be negative" 2 "robust_loop_chi2 must be finite and >= 0" -- "$LLC" graph --g2o "$TMP/square.g2o" --out "$TMP/x.g2o" --esdf/robust_loop_chi2 -1
check "graph: malformed g2o" 1 "bad.g2o:2: EDGE_SE2 needs" -- "$LLC" graph --g2o "$TMP/bad.g2o" --out "$TMP/x.g2o"
check "graph: missing file" 1 "none.g2o: no such file" -- "$LLC" graph --g2o "$TMP/none.g2o" --out "$TMP/x.g2o"
check "bag: front scanner topic renamed" 1 "no sensor_msgs/LaserScan on the front topic /front" -- "$LLC" features --log "$TMP/sim/sim.bag" --out "$TMP/f.csv" --front-topic /front
check "bag: a topic of another type" 1 "does not hold sensor_msgs/LaserScan" -- "$LLC" features --log "$TMP/sim/sim.bag" --out "$TMP/f.csv" --back-topic /odom
head -c 100000 "$TMP/sim/sim.bag" > "$TMP/cut.bag"
check "bag: truncated" 1 "cut.bag: (not a readable bag|the bag is damaged)" -- "$LLC" features --log "$TMP/cut.bag" --out "$TMP/f.csv"
check "simulate bad parking time" 2 "parking-mean-s must be" -- "$LLC" simulate --out "$TMP/sim" --parking-mean-s 0
check "simulate kidnap half given" 2 "give both --kidnap-at" -- "$LLC" simulate --out "$TMP/sim_k" --length-m 300 --kidnap-at 50
check "simulate frames out of the drive" 2 "must keep frames in" -- "$LLC" simulate --out "$TMP/sim_k" --length-m 300 --start-frame 10 --end-frame 999999
check "simulate kidnap outside the frames" 2 "must be frames after --start-frame" -- "$LLC" simulate --out "$TMP/sim_k" --length-m 300 --start-frame 100 --end-frame 300 --kidnap-at 50 --kidnap-to 200
# A kidnapped drive: 150 frames, then the drive from frame 50 on (odometry running on), as the
# localisation rostest's bag is made.
check "simulate kidnapped" 0 "frames=350 " -- "$LLC" simulate --out "$TMP/sim_k" --length-m 300 --start-frame 0 --end-frame 250 --kidnap-at 150 --kidnap-to 50
# Several robots joining a saved map of the fleet (--load-session with several inputs): every input joins it.
"$LLC" slam --log "$TMP/sim/sim.log" --split 2 --simultaneous --out "$TMP/fleet_day1" --quiet --save-session "$TMP/fleet.llcsession" >/dev/null 2>&1
check "slam: several robots join a saved map" 0 "^robots_joined=2 " -- "$LLC" slam --log "$TMP/sim/sim.log" --split 2 --simultaneous --evaluate --out "$TMP/fleet_day2" --quiet --load-session "$TMP/fleet.llcsession"
check "slam: several robots on a saved map, none wrongly" 0 "^wrong_loops_accepted=0 " -- cat "$TMP/fleet_day2/report.txt"
check "slam: several robots, a saved map that is no session" 1 "fleet_day2/report.txt" -- "$LLC" slam --log "$TMP/sim/sim.log" --split 2 --out "$TMP/fleet_bad" --quiet --load-session "$TMP/fleet_day2/report.txt"
# One map for months (--lifelong): a second day joins the saved map, which is saved extended.
check "slam --lifelong needs a session to save" 2 "give --save-session S" -- "$LLC" slam --log "$TMP/sim/sim.log" --lifelong --load-session "$TMP/sim.llcsession" --out "$TMP/life0"
check "slam --lifelong starts with no pose" 2 "continue-odometry does not apply" -- "$LLC" slam --log "$TMP/sim/sim.log" --lifelong --load-session "$TMP/sim.llcsession" --save-session "$TMP/life.llcsession" --continue-odometry --out "$TMP/life0"
check "slam --lifelong: the day joins the map, the map grows by it, never wrongly" 0 "^ok$" -- bash -c "'$LLC' slam --log '$TMP/sim/sim.log' --drift moderate --lifelong --load-session '$TMP/sim.llcsession' --save-session '$TMP/life.llcsession' --out '$TMP/life1' --quiet | awk -F'[= ]' '{v[\$1] = \$2} /^saved_map=/ {saved = \$4} END {print (v[\"robots_joined\"] == 1 && v[\"wrong_loops_accepted\"] == 0 && v[\"cross_robot_loops\"] >= 10 && v[\"map_keyframes\"] == saved + v[\"robot_0_keyframes\"] && saved > 100 && v[\"session_keyframes\"] > 100 && v[\"session_keyframes\"] < v[\"map_keyframes\"] * 2 / 3 ? \"ok\" : \"not ok\")}'"
check "slam --lifelong: session_keyframes.csv lists what the pruned session keeps" 0 "^ok$" -- bash -c "test \$((\$(wc -l < '$TMP/life1/session_keyframes.csv') - 1)) -eq \$(awk -F'[= ]' '/^session_keyframes=/ {print \$2}' '$TMP/life1/report.txt') && echo ok"
check "slam --lifelong: the next day loads the extended map" 0 "^ok$" -- bash -c "'$LLC' slam --log '$TMP/sim/sim.log' --drift moderate --drift-seed 2 --lifelong --load-session '$TMP/life.llcsession' --save-session '$TMP/life.llcsession' --out '$TMP/life2' --quiet | awk -F'[= ]' '/^saved_map=/ {saved = \$4} /^map_keyframes=/ {m = \$2} END {print (saved == $(awk -F'[= ]' '/^session_keyframes=/ {print $2}' "$TMP/life1/report.txt" 2>/dev/null || echo -1) && m > saved ? \"ok\" : \"not ok: \" saved \" \" m)}'"
check "slam --lifelong without --load-session: the first day's map, saved at bounded size" 0 "^ok$" -- bash -c "'$LLC' slam --log '$TMP/sim/sim.log' --lifelong --save-session '$TMP/day1.llcsession' --out '$TMP/life3' --quiet | awk -F'[= ]' '{v[\$1] = \$2} END {print (v[\"session_keyframes\"] > 50 && v[\"session_keyframes\"] < v[\"keyframes\"] && v[\"session_loops_dropped\"] > 0 ? \"ok\" : \"not ok\")}'"
check "slam --start-scan is for a later day of a drive" 2 "start-scan is for a later day" -- "$LLC" slam --log "$TMP/sim/sim.log" --start-scan 10 --out "$TMP/life4"
check "slam --lifelong: a day's scans must be some of the input's" 2 "must leave 2 scans or more" -- "$LLC" slam --log "$TMP/sim/sim.log" --lifelong --load-session "$TMP/day1.llcsession" --save-session "$TMP/day2.llcsession" --start-scan 100000 --out "$TMP/life4"
check "simulate one robot is no fleet" 2 "--robots must be 2 to 16" -- "$LLC" simulate --out "$TMP/sim_f" --length-m 300 --robots 1
check "simulate a fleet" 0 "fleet.bag \\(3 robots r1 .. r3\\)" -- "$LLC" simulate --out "$TMP/sim_f" --length-m 300 --robots 3
# The fleet's bag: each robot's topics under its namespace, one /tf_static; at once, all start at the first stamp.
check "simulate a fleet: its topics" 0 "^ok$" -- bash -c "source '$REPO/build/.ws/devel/setup.bash' && rosbag info -y -k topics '$TMP/sim_f/fleet.bag' | grep -c 'topic: /r[123]/scan_\\(front\\|back\\)' | awk '{print (\$1 == 6 ? \"ok\" : \"not ok: \" \$1)}'"

# Help for every subcommand: its usage with defaults, exit 0.
for sub in pairs features train evaluate score simulate align graph slam train-crf relations; do
  check "$sub --help" 0 "^usage: llc $sub " -- "$LLC" "$sub" --help
done
check "slam --help lists defaults" 0 "\[--drift-noise-m 0\.01\]" -- "$LLC" slam --help
check "align --help lists the aligner's parameters with defaults" 0 "^  --aligner/max_range 40   # " -- "$LLC" align --help
check "graph --help lists the ESDF's parameters with defaults" 0 "^  --esdf/loop_chi2_threshold 16.27   # " -- "$LLC" graph --help
check "align: a bool parameter flag takes true/false" 2 "aligner/validation/only_in_view': bad value" -- "$LLC" align --aligner/validation/only_in_view maybe --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/sim/a8.csv"
# Flags and outputs are checked before the run: nothing is written, no folder made.
check "slam: a NaN flag is refused before the run" 2 "positive-distance must be a number, not 'nan'" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam_nan" --positive-distance nan
check "slam: ... and left no output folder" 0 "^absent$" -- bash -c "test -e '$TMP/slam_nan' && echo present || echo absent"
check "slam: an unwritable --save-graph is refused before the run" 1 "--save-graph $TMP/no/such/g.g2o: cannot be written" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam_nograph" --save-graph "$TMP/no/such/g.g2o"
check "slam: an unwritable --save-session is refused before the run" 1 "--save-session $TMP/no/such/s.llcsession: cannot be written" -- "$LLC" slam --bag "$TMP/sim/sim.bag" --out "$TMP/slam_nosave" --save-session "$TMP/no/such/s.llcsession"
check "slam: ... and left no output folder" 0 "^absent$" -- bash -c "test -e '$TMP/slam_nosave' && echo present || echo absent"
check "features: --out a folder" 1 "--out $TMP/sim: cannot be written \(.* is a folder\)" -- "$LLC" features --log "$TMP/sim/sim.log" --out "$TMP/sim"
# A full disk: every output is checked, none left short or empty, an old one kept whole.
if [ -w /dev/full ]; then
  check "features to a full device" 1 "write to /dev/full failed: No space left on device" -- "$LLC" features --log "$TMP/sim/sim.log" --out /dev/full
  check "pairs to a full device" 1 "No space left on device" -- "$LLC" pairs --log "$TMP/sim/sim.log" --out /dev/full
fi
full_disk() {  # full_disk OUT_FILE command...: runs the command with writes past 1 KiB refused by the kernel
  local out="$1"; shift
  printf 'the old file\n' > "$out"
  bash -c 'trap "" XFSZ; ulimit -f 1; exec "$@"' full_disk "$@"
}
check "features, disk full: exit 1, named" 1 "write to $TMP/full_f.csv.tmp failed: File too large \($TMP/full_f.csv left as it was\)" -- full_disk "$TMP/full_f.csv" "$LLC" features --log "$TMP/sim/sim.log" --out "$TMP/full_f.csv"
check "pairs, disk full" 1 "File too large" -- full_disk "$TMP/full_p.csv" "$LLC" pairs --log "$TMP/sim/sim.log" --out "$TMP/full_p.csv"
check "score, disk full" 1 "File too large" -- full_disk "$TMP/full_s.csv" "$LLC" score --model "$TMP/sim/m.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/full_s.csv"
check "align, disk full" 1 "File too large" -- full_disk "$TMP/full_a.csv" "$LLC" align --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/full_a.csv"
check "disk full: the old files are kept whole, no temporary left" 0 "^ok$" -- bash -c "cat '$TMP'/full_[fpsa].csv | sort -u | grep -qx 'the old file' && [ \$(cat '$TMP'/full_[fpsa].csv | wc -l) -eq 4 ] && ! ls '$TMP'/full_*.tmp 2>/dev/null && echo ok"
# A line with more values than its beam count, a model that cannot match anything.
printf 'FLASER 2 1.0 2.0 3.0 4.0 0 0 0 0 0 0 1 h 1\n' > "$TMP/extra.log"
check "log: a line with more values than its beam count" 1 "extra.log:1: FLASER: 2 more values than a line with 2 beams" -- "$LLC" features --log "$TMP/extra.log" --out "$TMP/f.csv"
sed -E 's/alpha: [0-9.e+-]+/alpha: 0/' "$TMP/sim/m.yaml" > "$TMP/weightless.yaml"
check "model: no stump with a positive alpha" 1 "no stump has a positive alpha" -- "$LLC" score --model "$TMP/weightless.yaml" --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --out "$TMP/s.csv"
check "train: --rounds 0" 2 "rounds" -- "$LLC" train --data "$TMP/sim/sim.bag:$TMP/sim/bag_pairs.csv" --model "$TMP/r0.yaml" --rounds 0

DEMO_BAG="$DATA/rosbag/laser_scan_matcher_demo.bag"
if [ -f "$DEMO_BAG" ]; then
  # A bag no one here recorded: one /scan in '/laser', no /tf at all. The scanner falls back to
  # the base, said once, and the room maps.
  check "slam on a bag with no tf: the fallback mount said" 0 "/tf_static does not mount scanner frame 'laser'" -- "$LLC" slam --bag "$DEMO_BAG" --front-topic /scan --out "$TMP/slam_demo" --quiet
  check "slam on a bag with no tf: every scan used, keyframes made" 0 "^ok$" -- awk -F= '{v[$1] = $2} END {print (v["scans"] == 360 && v["skipped_scans"] == 0 && v["keyframes"] >= 10 ? "ok" : "not ok: " v["scans"] " " v["skipped_scans"] " " v["keyframes"])}' "$TMP/slam_demo/report.txt"
else
  echo "skipped the demo bag: $DEMO_BAG is absent"
fi

LOG="$DATA/carmen/intel-corrected.log.gz"
if [ -f "$LOG" ]; then
  if [ -f "$DATA/g2o/intel.g2o" ]; then
    check "graph on intel.g2o reaches the known optimum 45.0" 0 "^ok$" -- bash -c "'$LLC' graph --g2o '$DATA/g2o/intel.g2o' --out '$TMP/intel.g2o' | awk -F= '/^chi2=/ {print (\$2 < 45.45 ? \"ok\" : \"chi2 \" \$2)}'"
  fi
  RAW="$DATA/carmen/intel-raw-odometry.log.gz"
  if [ -f "$RAW" ]; then
    # Its poses run one scan ahead of its scans: auto must find -1, and the map then closes loops.
    check "slam on the raw Intel log finds its odometry offset" 0 "^odometry_offset=-1$" -- "$LLC" slam --log "$RAW" --out "$TMP/slam_intel" --odometry-offset auto --quiet
    check "slam on the raw Intel log applies loops" 0 "^ok$" -- awk -F= '/^loops_accepted=/ {print ($2 >= 150 ? "ok" : "loops " $2)}' "$TMP/slam_intel/report.txt"
    check "odometry offset not a number" 2 "odometry-offset" -- "$LLC" slam --log "$RAW" --out "$TMP/slam_bad" --odometry-offset soon --quiet
  fi
  MIT="$DATA/relations/mit-csail.log.gz"
  if [ -f "$MIT" ]; then
    # The Kümmerle benchmark: every relation evaluated on the run's own per-scan poses; the same
    # figure again from scans.csv by llc relations, and near it from the keyframes alone.
    CSAIL_TRUTH="$DATA/carmen/csail-corrected.log.gz"
    check "slam --relations on MIT CSAIL" 0 "^relations_evaluated=1172$" -- "$LLC" slam --log "$MIT" --out "$TMP/mit" --odometry-offset auto --relations "${MIT%.log.gz}.relations" --quiet --truth "$CSAIL_TRUTH" --wrong-loop-deg 15
    # Its SLAM-corrected log holds 406 of its scans: the truth for loops (1 m / 15 degrees, as
    # scripts/benchmark_relations judges them).
    check "MIT CSAIL: the corrected log's scans found" 0 "^truth_scans_matched=406 " -- cat "$TMP/mit/report.txt"
    check "MIT CSAIL: no wrong loop against the corrected log" 0 "^wrong_loops_accepted=0$" -- cat "$TMP/mit/report.txt"
    # Its scans come one scan after their odometry: -1 scans, 0.21 s for a bag and the nodelets.
    check "MIT CSAIL: the odometry offset in seconds" 0 "^odometry_time_offset_suggested=-0.21 " -- cat "$TMP/mit/report.txt"
    check "MIT CSAIL relations: mean translational error under 0.1 m" 0 "^ok$" -- awk -F= '/^relation_translation_mean_m=/ {print ($2 < 0.1 ? "ok" : "error " $2)}' "$TMP/mit/report.txt"
    mean="$(sed -n 's/^relation_translation_mean_m=//p' "$TMP/mit/report.txt")"
    check "llc relations on scans.csv gives slam's figure" 0 "^relation_translation_mean_m=$mean$" -- "$LLC" relations --log "$MIT" --poses "$TMP/mit/scans.csv" --relations "${MIT%.log.gz}.relations" --out "$TMP/mit/errors.csv"
    check "llc relations on the keyframes, carried by odometry" 0 "^relations_carried=[1-9]" -- "$LLC" relations --log "$MIT" --keyframes "$TMP/mit/trajectory.csv" --relations "${MIT%.log.gz}.relations"
    check "relation_tail on MIT CSAIL: every relation, and where its largest ones hang" 0 "^relations=1172 " -- /usr/bin/python3 "$REPO/scripts/lib/relation_tail.py" "$TMP/mit"
    MIT_BAG="$DATA/rosbag/mit-csail.bag"
    if [ -f "$MIT_BAG" ]; then
      # Its bag stamps each scan a scan after its odometry: the estimate, as the nodelets make it.
      check "slam --bag on MIT CSAIL: the odometry time offset found" 0 "^odometry_time_offset=-0.21 .*from scan 156 on" -- \
        sh -c "'$LLC' slam --bag '$MIT_BAG' --front-topic /scan --out '$TMP/mit_bag' --quiet && cat '$TMP/mit_bag/report.txt'"
    fi
    check "relations: poses of another log" 1 "not in the log" -- "$LLC" relations --log "$TMP/sim/sim.log" --poses "$TMP/mit/scans.csv" --relations "${MIT%.log.gz}.relations"
  fi
  FR079_LOG="$DATA/relations/fr079.log.gz"
  if [ -f "$FR079_LOG" ] && [ -f "$DATA/relations/fr079.relations" ]; then
    # FR079 reverses through a turn at scans 1854-1867 while its wheels count the reverse as
    # forward: scan 1863, between keyframes, disputed with the wheels, ICP from their guess and
    # from the tracked pose ends 0.3 rad off (relations 393 and 419: 0.47 m), ICP from the laser's
    # own prediction where the reference puts it. 200 scans of the log, with llc slam's benchmark settings.
    zcat "$FR079_LOG" | awk '/^FLASER/ {n++} n >= 1700 && n < 1900 {print} /^FLASER/ && n >= 1900 {exit}' >"$TMP/fr079_reverse.log"
    "$LLC" slam --log "$TMP/fr079_reverse.log" --out "$TMP/fr079_reverse" --odometry-offset auto --odometry/match_every_scan true --relations "$DATA/relations/fr079.relations" --quiet >/dev/null 2>&1
    check "FR079 reversing, wheels counting forward: a disputed scan placed from the laser's prediction" 0 "^scans_placed_by_prediction=[1-9]" -- cat "$TMP/fr079_reverse/report.txt"
    check "FR079 reversing: scan 1863 where the reference relations put it (< 0.1 m)" 0 "^ok$" -- awk -F, '$1 == 393 || $1 == 419 {n++; if ($6 >= 0.1) bad++} END {print (n == 2 && !bad ? "ok" : "not ok: " n " relations, " bad + 0 " off")}' "$TMP/fr079_reverse/relation_errors.csv"
    # Turning at scans 4479-4488, ICP from the wheels' seed ends keyframe 4483 0.36 rad off at
    # 0.65 overlap; the no-guess alignment fits (the reference relations agree): relation 428
    # 0.24 m without realign_below_overlap, under 0.05 with it. Scans 4300-4599 of the log.
    zcat "$FR079_LOG" | awk '/^FLASER/ {n++} n >= 4300 && n < 4600 {print} /^FLASER/ && n >= 4600 {exit}' >"$TMP/fr079_turn.log"
    "$LLC" slam --log "$TMP/fr079_turn.log" --out "$TMP/fr079_turn" --odometry-offset -1 --odometry/match_every_scan true --relations "$DATA/relations/fr079.relations" --quiet >/dev/null 2>&1
    check "FR079 turning: a keyframe step ICP overlapped little, realigned with no guess" 0 "^odometry_steps_realigned=[1-9]" -- cat "$TMP/fr079_turn/report.txt"
    check "FR079 turning: keyframe 4483 where the reference relations put it (< 0.05 m)" 0 "^ok$" -- awk -F, '$1 == 428 {n++; if ($6 >= 0.05) bad++} END {print (n == 1 && !bad ? "ok" : "not ok")}' "$TMP/fr079_turn/relation_errors.csv"
  fi
  FR079_BAG="$DATA/rosbag/fr079.bag"
  if [ -f "$FR079_BAG" ] && [ -f "$DATA/relations/fr079.relations" ]; then
    # The relations give the scanner's motion; the FR079 bag mounts its scanner 0.04 m ahead of
    # base_link. Base poses whose scanner moves exactly as relation 46 (a turn of -2.17 rad):
    # no error against the bag; 0.0707 m against the log, which mounts nothing.
    awk 'BEGIN { rx = -0.001790; ry = -0.072020; rt = -2.170150
                 printf "stamp,x,y,theta\n1239.470241,0,0,0\n1242.670535,%.9f,%.9f,%.9f\n", 0.04 + rx - 0.04 * cos(rt), ry - 0.04 * sin(rt), rt }' >"$TMP/fr079_turn.csv"
    "$LLC" relations --log "$FR079_BAG" --front-topic /scan --keyframes "$TMP/fr079_turn.csv" --relations "$DATA/relations/fr079.relations" --out "$TMP/fr079_bag_errors.csv" >/dev/null 2>&1
    check "relations on a bag: the scanner's motion (its mount from the bag)" 0 "^46,.*,129,144,0.000000,0.000000,0$" -- cat "$TMP/fr079_bag_errors.csv"
    "$LLC" relations --log "$DATA/relations/fr079.log.gz" --keyframes "$TMP/fr079_turn.csv" --relations "$DATA/relations/fr079.relations" --out "$TMP/fr079_log_errors.csv" >/dev/null 2>&1
    check "relations on the log: no mount, the base's turn moves the scanner" 0 "^46,.*,129,144,0.070747,0.000000,0$" -- cat "$TMP/fr079_log_errors.csv"
    # Poses made on the bag, carried by the log: the bag's mount, the log's odometry.
    "$LLC" relations --log "$DATA/relations/fr079.log.gz" --mount-from "$FR079_BAG" --front-topic /scan --keyframes "$TMP/fr079_turn.csv" --relations "$DATA/relations/fr079.relations" --out "$TMP/fr079_mounted_errors.csv" >/dev/null 2>&1
    check "relations on the log with --mount-from the bag" 0 "^46,.*,129,144,0.000000,0.000000,0$" -- cat "$TMP/fr079_mounted_errors.csv"
    check "relations --mount-from a log, not a bag" 2 "mount-from takes the bag" -- "$LLC" relations --log "$DATA/relations/fr079.log.gz" --mount-from "$DATA/relations/fr079.log.gz" --keyframes "$TMP/fr079_turn.csv" --relations "$DATA/relations/fr079.relations"
  fi
  check "pairs" 0 "pairs=400" -- "$LLC" pairs --log "$LOG" --out "$TMP/pairs.csv"
  head -1 "$TMP/pairs.csv" | grep -qx "a,b,label" && passed=$((passed + 1)) || { failed=$((failed + 1)); echo "FAIL: pair header"; }
  printf 'a,b,label\n0,99999,1\n' > "$TMP/range.csv"
  check "index out of range" 1 "scan index 99999 out of range" -- "$LLC" score --data "$LOG:$TMP/range.csv" --out "$TMP/s.csv"
  check "features" 0 "scans=910 features=" -- "$LLC" features --log "$LOG" --out "$TMP/features.csv"
  check "train" 0 "rounds=50" -- "$LLC" train --data "$LOG:$TMP/pairs.csv" --model "$TMP/model.yaml" --repeats 1
  check "score" 0 "pairs=400" -- "$LLC" score --model "$TMP/model.yaml" --data "$LOG:$TMP/pairs.csv" --out "$TMP/scores.csv"
  head -1 "$TMP/scores.csv" | grep -qx "a,b,label,score" && passed=$((passed + 1)) || { failed=$((failed + 1)); echo "FAIL: score header"; }
  check "bad folds" 2 "folds must be at least 2" -- "$LLC" evaluate --data "$LOG:$TMP/pairs.csv" --out "$TMP/eval" --folds 0
  out="$("$LLC" evaluate --data "$LOG:$TMP/pairs.csv" --out "$TMP/eval" --repeats 2 --curve-max-rounds 60 2>&1)"
  last2="$(tail -2 <<<"$out")"
  if grep -qE '^detection_at_1pct_fa=[01]\.[0-9]+$' <<<"$(head -1 <<<"$last2")" && grep -qE '^auc=[01]\.[0-9]+$' <<<"$(tail -1 <<<"$last2")" \
     && [ -s "$TMP/eval/roc.csv" ] && [ -s "$TMP/eval/error_vs_rounds.csv" ] && [ -s "$TMP/eval/feature_removal.csv" ]; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1)); echo "FAIL: evaluate output"; echo "$out" | tail -6
  fi
  auc="$(sed -n 's/^auc=//p' <<<"$last2")"
  if awk -v a="$auc" 'BEGIN { exit !(a > 0.8) }'; then passed=$((passed + 1)); else failed=$((failed + 1)); echo "FAIL: auc $auc <= 0.8 on intel"; fi
else
  echo "skipped the real-log round: $LOG is absent"
fi
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
