#!/bin/bash
# The full check of the calibrated participant model on exp2 (docs/PARTICIPANTS.md, "Where the
# model stands"): runs protocols/studies/exp2_short_term.json with virtual participants, reports
# the wall time, exports the measures and compares the post-training palpation force and
# exploration time with the people's (tests/data/calibration/exp2_human.csv), all of it from
# `palplab stats` on both CSVs (one reader, one set of statistics; the study's analyses: one-way
# ANOVA, pairwise Welch t-tests with exact df):
#   - per group: people's mean ± SD (n), model's mean ± SD (n), z of the model's mean in units of
#     the people's standard error, and whether it lies inside the people's 95 % t interval;
#   - whether the order of the group means of each measure is the people's;
#   - the verdict at .05 of the ANOVA and of every pairwise test: people's p, model's p, same or
#     DIFFERENT (p as `palplab stats` prints it, 4 significant digits).
# The people's data are checked before the simulation (each measure must be analysable in PHASE:
# `palplab stats`' own error otherwise), and their groups must be the model's.
# Exit status: 0 = both orders as in the people's data, 1 = an order differs (the verdicts and
# intervals are reported, not part of the status), 2 = a run failed or the data cannot be compared.
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
measures="palpation_force exploration_time"
fail() {
  echo "exp2_check: $*" >&2
  exit 2
}

# `palplab stats` of one measure in PHASE as lines (fields separated by tabs):
#   group <g> <n> <mean> <sd> <se> <ci low> <ci high>
#   test ANOVA <p>
#   test <a> <b> <p>            (a pairwise Welch test)
# Group ids may hold blanks: the numbers are taken from the end of each row.
stats_lines() {
  "$palplab" stats --csv "$1" --value value --group group --where "phase=$phase" \
    --where "measure=$2" --skip-empty 2>"$out/stats.err" |
    awk -v OFS='\t' '
      function head(last,   i, t) { t = $1; for (i = 2; i <= last; i++) t = t " " $i; return t }
      /^[A-Z]/ { s = $0; next }
      # group n mean sd se median min max [lo, hi]: the numbers counted back from the "[".
      s == "Descriptives" && $1 != "group" && /\[/ {
        for (j = 1; j <= NF && $j !~ /^\[/; j++) {}
        ci = $0; sub(/.*\[/, "", ci); sub(/\].*/, "", ci); split(ci, c, ",");
        print "group", head(j - 8), $(j - 7), $(j - 6), $(j - 5), $(j - 4), c[1] + 0, c[2] + 0 }
      s == "One-way ANOVA" && $1 == "between" { print "test", "ANOVA", $6 }
      # a - b, then mean diff, t, df, p, p Holm, p Bonf., Hedges g (the APA lines have a ":").
      s ~ /^Pairwise/ && NF >= 10 && $1 != "pair" && !/:/ {
        pair = head(NF - 7); i = index(pair, " - ");
        print "test", substr(pair, 1, i - 1), substr(pair, i + 3), $(NF - 3) }'
  local rc=${PIPESTATUS[0]}
  if [ "$rc" -ne 0 ]; then
    echo "$(cat "$out/stats.err") ($1, measure $2, phase $phase)"
    return 1
  fi
}

mkdir -p "$out" || fail "cannot create $out"
[ -r "$human" ] || fail "cannot read the people's data $human"
# The people's data first: a measure or phase they lack is found before the simulation.
declare -A H S
for m in $measures; do
  H[$m]=$(stats_lines "$human" "$m") || fail "people's data: ${H[$m]}"
done

start=$(date +%s.%N)
# shellcheck disable=SC2086
"$palplab" run "$study" --db "$out/exp2.db" --jobs "$jobs" --samples none --quiet --force \
  ${EXTRA:-} || fail "palplab run $study failed"
end=$(date +%s.%N)
"$palplab" export "$out/exp2.db" --csv "$out/csv" >/dev/null || fail "palplab export failed"
wall=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
echo "wall time of \`palplab run\` (--jobs $jobs): $wall s"
for m in $measures; do
  S[$m]=$(stats_lines "$out/csv/measures.csv" "$m") || fail "model's data: ${S[$m]}"
  hg=$(awk -F'\t' '$1 == "group" { print $2 }' <<<"${H[$m]}" | sort | paste -sd,)
  sg=$(awk -F'\t' '$1 == "group" { print $2 }' <<<"${S[$m]}" | sort | paste -sd,)
  [ "$hg" = "$sg" ] ||
    fail "$m in phase $phase: the people's groups ($hg) are not the model's ($sg)"
done

# The comparison, one awk over both: people's lines (file 1), then the model's (file 2).
status=0
for m in $measures; do
  awk -F'\t' -v m="$m" '
    FNR == 1 { f++ }
    $1 == "group" { n[f, $2] = $3; mean[f, $2] = $4; sd[f, $2] = $5; se[f, $2] = $6;
                    lo[f, $2] = $7; hi[f, $2] = $8; if (f == 1) g[++ng] = $2 }
    $1 == "test" && $2 == "ANOVA" { p[f, "ANOVA"] = $3; if (f == 1) t[++nt] = "ANOVA" }
    $1 == "test" && $2 != "ANOVA" {
      k = $2 < $3 ? $2 " - " $3 : $3 " - " $2;  # a pair in either order
      p[f, k] = $4; if (f == 1) t[++nt] = k }
    function order(f,   i, j, x, o, s) {
      for (i = 1; i <= ng; i++) o[i] = g[i];
      for (i = 1; i <= ng; i++) for (j = i + 1; j <= ng; j++)
        if (mean[f, o[j]] > mean[f, o[i]]) { x = o[i]; o[i] = o[j]; o[j] = x }
      s = o[1]; for (i = 2; i <= ng; i++) s = s " > " o[i];
      return s }
    END {
      printf "\n| %s | group | people mean ± SD (n) | model mean ± SD (n) | z | people 95 %% CI | inside |\n", m;
      print "|---|---|---|---|---|---|---|";
      for (i = 1; i <= ng; i++) {
        x = g[i]; z = se[1, x] > 0 ? (mean[2, x] - mean[1, x]) / se[1, x] : 0;
        in_ = mean[2, x] >= lo[1, x] && mean[2, x] <= hi[1, x]; inside += in_;
        printf "| %s | %s | %.2f ± %.2f (%d) | %.2f ± %.2f (%d) | %+.2f | [%.4g, %.4g] | %s |\n",
               m, x, mean[1, x], sd[1, x], n[1, x], mean[2, x], sd[2, x], n[2, x], z,
               lo[1, x], hi[1, x], in_ ? "yes" : "NO" }
      ho = order(1); so = order(2);
      printf "order of %s: people %s, model %s: %s\n", m, ho, so, ho == so ? "same" : "DIFFERENT";
      printf "\n| %s | test | people p | model p | verdict at .05 |\n", m;
      print "|---|---|---|---|---|";
      for (i = 1; i <= nt; i++) {
        k = t[i];
        if (!((2, k) in p)) { printf "| %s | %s | %s | (none) | not compared |\n", m, k, p[1, k]; continue }
        hs = p[1, k] + 0 < 0.05; ms = p[2, k] + 0 < 0.05; same += hs == ms; tests++;
        printf "| %s | %s | %s | %s | %s: %s%s |\n", m, k, p[1, k], p[2, k],
               hs == ms ? "same" : "DIFFERENT", hs ? "significant" : "not significant",
               hs == ms ? "" : ms ? " (model: significant)" : " (model: not significant)" }
      printf "%s: verdicts as the people'\''s %d of %d, model means inside the people'\''s 95 %% CI %d of %d\n",
             m, same, tests, inside, ng;
      exit (ho != so) }' <(printf '%s\n' "${H[$m]}") <(printf '%s\n' "${S[$m]}") || status=1
done
exit $status
