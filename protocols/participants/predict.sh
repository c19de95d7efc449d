#!/bin/bash
# Predictions of the calibrated participant model for the reference studies that were NOT used
# for calibration (docs/PARTICIPANTS.md, "Predictions"): runs each study with the shipped
# defaults, exports it and prints a Markdown table of the group means ± SD of palpation force
# and exploration time per phase's last session. Nothing here feeds back into the parameters.
# Usage (from the repository root, after building): protocols/participants/predict.sh [OUTDIR]
#   PALPLAB (default build/palplab), JOBS (default 2), STUDIES (default exp1 exp3 exp4),
#   SIZE (every group resized to SIZE participants: a reduced run when time is short; same seed,
#   design and timing — the study copy is written to OUTDIR and says so in the table).
set -euo pipefail
out=${1:-predictions}
palplab=${PALPLAB:-build/palplab}
jobs=${JOBS:-2}
studies=${STUDIES:-"exp1_instructor exp3_long_term exp4_visual_extent"}
mkdir -p "$out"
echo "| study | phase | session | group | measure | n | mean | SD |"
echo "|---|---|---|---|---|---|---|---|"
for s in $studies; do
  file="protocols/studies/$s.json"
  if [ -n "${SIZE:-}" ]; then
    sed -E "s/\"size\": *[0-9]+/\"size\": $SIZE/" "$file" >"$out/$s.json"
    file="$out/$s.json"
  fi
  PALPLAB_PROTOTYPE_PATH="$PWD/prototypes" \
    "$palplab" run "$file" --db "$out/$s.db" --jobs "$jobs" --samples none --quiet --force
  "$palplab" export "$out/$s.db" --csv "$out/$s" >/dev/null
  awk -F, -v study="$s${SIZE:+ (n=$SIZE per group)}" 'NR > 1 && ($5 == "palpation_force" || $5 == "exploration_time") &&
      $6 != "" && $6 != "NA" {
        k = $3 SUBSEP $4 SUBSEP $2 SUBSEP $5; n[k]++; s1[k] += $6; s2[k] += $6 * $6 }
    END { for (k in n) { split(k, f, SUBSEP); m = s1[k] / n[k];
            v = n[k] > 1 ? (s2[k] - n[k] * m * m) / (n[k] - 1) : 0; if (v < 0) v = 0;
            printf "| %s | %s | %s | %s | %s | %d | %.2f | %.2f |\n", study, f[1], f[2], f[3],
                   f[4], n[k], m, sqrt(v) } }' "$out/$s/measures.csv" | sort
done
