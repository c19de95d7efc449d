#!/bin/bash
# The full check of the calibrated participant model on exp2 (docs/PARTICIPANTS.md, "The exp2
# check"): runs protocols/studies/exp2_short_term.json with virtual participants, reports the
# wall time, exports the measures and prints per group the post-training palpation force and
# exploration time (mean ± SD, n) next to the human values of exp2_human.csv, the z of each
# simulated mean in units of the human group's standard error, and whether the order of the
# group means of both measures is the human one; then, from `palplab stats` on both CSVs, the
# verdict at .05 of the one-way ANOVA and of every pairwise Welch t-test (human p, model p, same
# or DIFFERENT) and whether each model mean lies inside the human group's 95 % t interval.
# Exit status: 0 = both orders as in the human data, 1 = an order differs, 2 = a run failed
# (the verdicts and intervals are reported, not part of the status).
# Usage (from the repository root, after building):
#   protocols/participants/exp2_check.sh [OUTDIR]
#   PALPLAB (default build/palplab), JOBS (default 2), STUDY (default the exp2 study file),
#   HUMAN (default tests/data/calibration/exp2_human.csv), EXTRA (extra `palplab run` flags),
#   PHASE (default post_training: the phase compared).
set -uo pipefail
out=${1:-exp2_check}
palplab=${PALPLAB:-build/palplab}
jobs=${JOBS:-2}
study=${STUDY:-protocols/studies/exp2_short_term.json}
human=${HUMAN:-tests/data/calibration/exp2_human.csv}
phase=${PHASE:-post_training}
mkdir -p "$out"
start=$(date +%s.%N)
# shellcheck disable=SC2086
"$palplab" run "$study" --db "$out/exp2.db" --jobs "$jobs" --samples none --quiet --force \
  ${EXTRA:-} || exit 2
end=$(date +%s.%N)
"$palplab" export "$out/exp2.db" --csv "$out/csv" >/dev/null || exit 2
wall=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
echo "wall time of \`palplab run\` (--jobs $jobs): $wall s"
# Both CSVs: participant,group,phase,session,measure,value[,...]; the post-training phase only.
awk -F, -v phase="$phase" '
  FNR == 1 { file++; next }
  $3 != phase || ($5 != "palpation_force" && $5 != "exploration_time") { next }
  $6 == "" || $6 == "NA" { undef[file, $2, $5]++; next }
  { k = file SUBSEP $2 SUBSEP $5; n[k]++; s1[k] += $6; s2[k] += $6 * $6; groups[$2] = 1 }
  END {
    split("palpation_force exploration_time", ms, " ");
    ng = 0; for (g in groups) gl[++ng] = g;
    for (i = 1; i <= ng; i++) for (j = i + 1; j <= ng; j++) if (gl[j] < gl[i]) { t = gl[i]; gl[i] = gl[j]; gl[j] = t }
    printf "| measure | group | human mean ± SD (n) | model mean ± SD (n, undefined) | z of model mean |\n";
    printf "|---|---|---|---|---|\n";
    bad = 0;
    for (mi = 1; mi <= 2; mi++) {
      m = ms[mi]; ho = ""; so = "";
      for (i = 1; i <= ng; i++) {
        g = gl[i];
        for (f = 1; f <= 2; f++) {
          k = f SUBSEP g SUBSEP m; c = n[k];
          mean[f, g] = c ? s1[k] / c : 0;
          v = c > 1 ? (s2[k] - c * mean[f, g] ^ 2) / (c - 1) : 0; sd[f, g] = v > 0 ? sqrt(v) : 0;
        }
        se = n[2 SUBSEP g SUBSEP m] ? sd[2, g] / sqrt(n[2 SUBSEP g SUBSEP m]) : 0;
        z = se > 0 ? (mean[1, g] - mean[2, g]) / se : 0;
        printf "| %s | %s | %.2f ± %.2f (%d) | %.2f ± %.2f (%d, %d) | %+.2f |\n", m, g,
               mean[2, g], sd[2, g], n[2 SUBSEP g SUBSEP m], mean[1, g], sd[1, g],
               n[1 SUBSEP g SUBSEP m], undef[1, g, m], z;
      }
      # Order of the group means, largest first.
      for (f = 1; f <= 2; f++) {
        for (i = 1; i <= ng; i++) o[i] = gl[i];
        for (i = 1; i <= ng; i++) for (j = i + 1; j <= ng; j++)
          if (mean[f, o[j]] > mean[f, o[i]]) { t = o[i]; o[i] = o[j]; o[j] = t }
        str = o[1]; for (i = 2; i <= ng; i++) str = str " > " o[i];
        if (f == 1) so = str; else ho = str;
      }
      ok = (so == ho);
      if (!ok) bad = 1;
      order[mi] = sprintf("order of %s: human %s, model %s: %s", m, ho, so, ok ? "same" : "DIFFERENT");
    }
    print "";
    for (mi = 1; mi <= 2; mi++) print order[mi];
    exit bad
  }' "$out/csv/measures.csv" "$human"
status=$?

# The verdicts and intervals, from palplab's own statistics on both CSVs (the study's analyses:
# one-way ANOVA, pairwise Welch t-tests with exact df). One line per item:
#   test ANOVA <p> | test <a>-vs-<b> <p> | group <g> <mean> <ci low> <ci high>
stats_lines() {
  "$palplab" stats --csv "$1" --value value --group group --where "phase=$phase" \
    --where "measure=$2" --skip-empty |
    awk '
      /^[A-Z]/ { s = $0; next }
      s == "Descriptives" && $1 != "group" && /\[/ {
        ci = $0; sub(/.*\[/, "", ci); sub(/\].*/, "", ci); split(ci, c, ",");
        print "group", $1, $3, c[1] + 0, c[2] + 0 }
      s == "One-way ANOVA" && $1 == "between" { print "test", "ANOVA", $6 }
      s ~ /^Pairwise/ && $2 == "-" { print "test", $1 "-vs-" $3, $7 }'
}
# Field $3 of the item of kind $1 named $2 in the lines $4 (field 3: the p or the mean).
value_of() { awk -v k="$1" -v n="$2" -v f="$3" '$1 == k && $2 == n { print $f }' <<<"$4"; }
echo
verdicts=0 same=0 means=0 inside=0
for m in palpation_force exploration_time; do
  h=$(stats_lines "$human" "$m") || exit 2
  s=$(stats_lines "$out/csv/measures.csv" "$m") || exit 2
  if [ -z "$h" ] || [ -z "$s" ]; then continue; fi
  echo "| $m | test | human p | model p | verdict at .05 |"
  echo "|---|---|---|---|---|"
  while read -r _ name hp; do
    mp=$(value_of test "$name" 3 "$s")
    [ -n "$mp" ] || continue
    verdict=$(awk -v hp="$hp" -v mp="$mp" 'BEGIN {
      hs = hp + 0 < 0.05; ms = mp + 0 < 0.05;
      printf "%s: %s", hs == ms ? "same" : "DIFFERENT", hs ? "significant" : "not significant";
      if (hs != ms) printf " (model: %s)", ms ? "significant" : "not significant" }')
    verdicts=$((verdicts + 1))
    [ "${verdict%%:*}" = same ] && same=$((same + 1))
    echo "| $m | ${name//-vs-/ - } | $hp | $mp | $verdict |"
  done < <(grep '^test ' <<<"$h")
  echo
  echo "| $m | group | human 95 % CI of the mean | model mean | inside |"
  echo "|---|---|---|---|---|"
  while read -r _ g _ lo hi; do
    mm=$(value_of group "$g" 3 "$s")
    [ -n "$mm" ] || continue
    in=$(awk -v m="$mm" -v lo="$lo" -v hi="$hi" 'BEGIN { print (m + 0 >= lo + 0 && m + 0 <= hi + 0) ? "yes" : "NO" }')
    means=$((means + 1))
    [ "$in" = yes ] && inside=$((inside + 1))
    echo "| $m | $g | [$lo, $hi] | $mm | $in |"
  done < <(grep '^group ' <<<"$h")
  echo
done
echo "verdicts as the human's: $same of $verdicts; model means inside the human 95 % CI: $inside of $means"
exit $status
