# lme4's fit of the singular random-slope fixture (singular.csv: 2 groups x 6 participants x 5
# sessions with no participant slope variation, the report test's learning-curve data), for
# TEST(LmmSingular, ...) in tests/analysis/test_lmm.cpp. Run once from this directory:
#   Rscript make_singular_reference.R > singular_reference.txt   (lme4 1.1.31, R 4.2.2)
# Output per method: REML/ML flag, theta (3), sigma, REMLcrit or ML deviance, fixed effects (4),
# isSingular.
suppressMessages(library(lme4))
d <- read.csv("singular.csv")
for (r in c(TRUE, FALSE)) {
  m <- lmer(value ~ group * session + (1 + session | participant), d, REML = r)
  crit <- if (r) REMLcrit(m) else deviance(m)
  # The fixture exists to be singular; a regular fit would make the reference pointless.
  stopifnot(isSingular(m), is.finite(crit), all(is.finite(fixef(m))))
  cat(if (r) "REML" else "ML", sprintf("%.17g", c(getME(m, "theta"), sigma(m), crit, fixef(m))),
      isSingular(m), "\n")
}
