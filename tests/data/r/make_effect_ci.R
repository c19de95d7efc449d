# Reference values for TEST(VsR, AnovaEffectSizeCi) and TEST(VsR, NoncentralFGrid)
# (tests/analysis/test_vs_r.cpp), base R only (pf with ncp, uniroot; no CRAN packages):
#   Rscript make_effect_ci.R > effect_ci.csv      (R 4.2.2 of Debian 12 produced the file)
# Part 1, per fixture (the one-way ANOVA of its groups, in order of first appearance):
#   F, df1, df2                 from anova(lm(y ~ g))
#   lambda.lo/.hi               95 % interval of the noncentrality: pf(F, df1, df2, ncp = l)
#                               = .975 / .025 solved by uniroot (bound 0 when pf at ncp 0
#                               is already below; Steiger 2004)
#   pve.lo/.hi                  lambda / (lambda + df1 + df2 + 1): the population proportion of
#                               variance explained (the interval for eta^2 and omega^2)
#   Also at level .90 (lambda90.*, pve90.*).
# Part 2 (fixture "grid"): pf(x, d1, d2, ncp) on a grid, keys cdf:<d1>:<d2>:<ncp>:<x>.
# R's pnbeta stops at errmax 1e-9 (absolute), so the C++ test uses tolerances of that order.
options(warn = -1)
fixtures <- list(
  list(id = "unequal", file = "unequal.csv", value = "force", where = NULL),
  list(id = "unequal_post", file = "unequal.csv", value = "force", where = c("phase", "post")),
  list(id = "ties", file = "ties.csv", value = "score", where = NULL),
  list(id = "large", file = "large.csv", value = "value", where = NULL),
  list(id = "close", file = "close.csv", value = "value", where = NULL),
  list(id = "n2", file = "n2.csv", value = "value", where = NULL))
cat("fixture,key,value\n")
out <- function(id, key, v) cat(sprintf("%s,%s,%.17g\n", id, key, v))
lambda_for <- function(f, d1, d2, p) {
  g <- function(l) pf(f, d1, d2, ncp = l) - p
  if (g(0) <= 0) return(0)
  hi <- max(1, d1 * f)
  while (g(hi) > 0) hi <- hi * 2
  root <- uniroot(g, c(0, hi), tol = 1e-13)$root
  # The bound must solve its equation (R's pnbeta is good to about 1e-9 absolute).
  stopifnot(abs(g(root)) < 1e-8)
  root
}
for (f in fixtures) {
  d <- read.csv(f$file, stringsAsFactors = FALSE)
  if (!is.null(f$where)) d <- d[d[[f$where[1]]] == f$where[2], ]
  y <- d[[f$value]]
  g <- factor(d$group, levels = unique(d$group))
  a <- anova(lm(y ~ g))
  F <- a[1, "F value"]; d1 <- a[1, "Df"]; d2 <- a[2, "Df"]
  out(f$id, "F", F); out(f$id, "df1", d1); out(f$id, "df2", d2)
  for (lev in c(0.95, 0.90)) {
    tag <- if (lev == 0.95) "" else "90"
    lo <- lambda_for(F, d1, d2, 1 - (1 - lev) / 2)
    hi <- lambda_for(F, d1, d2, (1 - lev) / 2)
    n <- d1 + d2 + 1
    stopifnot(lo <= hi, hi > 0)  # an interval, and the observed F is above its lower tail
    out(f$id, paste0("lambda", tag, ".lo"), lo); out(f$id, paste0("lambda", tag, ".hi"), hi)
    out(f$id, paste0("pve", tag, ".lo"), lo / (lo + n)); out(f$id, paste0("pve", tag, ".hi"), hi / (hi + n))
  }
}
for (d1 in c(1, 2, 3.5, 9)) for (d2 in c(2.5, 12, 117, 4000)) for (ncp in c(0, 0.5, 7, 60, 800))
  for (x in c(0.05, 0.8, 2.5, 9, 40))
    {
      p <- pf(x, d1, d2, ncp = ncp)
      # A CDF value, and at ncp 0 R's noncentral code agrees with its central F.
      stopifnot(p >= 0, p <= 1, ncp > 0 || abs(p - pf(x, d1, d2)) < 1e-9)
      out("grid", sprintf("cdf:%g:%g:%g:%g", d1, d2, ncp, x), p)
    }
