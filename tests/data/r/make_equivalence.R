# Reference values for TEST(VsR, EquivalenceAndWelchEffectSize) (tests/analysis/test_vs_r.cpp),
# base R only:  Rscript make_equivalence.R > equivalence.csv   (R 4.2.2 produced the file)
# Per pair a.b (groups in order of first appearance; differences mean(a) - mean(b)):
#   dw.a.b.lo/.hi   Welch-consistent 95 % interval of Cohen's d: Welch's t inverted in the
#                   noncentral t (pt with ncp, uniroot), times SE_welch / pooled SD
#   tost.a.b.*      TOST with margins ±7 % of the fixture's grand mean: p_low from
#                   t.test(mu = -m, alternative = "greater"), p_high from t.test(mu = m,
#                   alternative = "less"), p = max, the 90 % Welch interval, and the verdict
#                   (equivalent if p < .05, else different if Welch's p < .05, else inconclusive)
options(warn = -1)
fixtures <- list(
  list(id = "unequal", file = "unequal.csv", value = "force", where = NULL),
  list(id = "unequal_post", file = "unequal.csv", value = "force", where = c("phase", "post")),
  list(id = "ties", file = "ties.csv", value = "score", where = NULL),
  list(id = "large", file = "large.csv", value = "value", where = NULL),
  # Made for this test (seed 11): two tight groups whose difference lies inside the margins.
  #   set.seed(11); value = round(c(rnorm(40, 10, .6), rnorm(40, 10.1, .6), rnorm(40, 10.3, 1.4)), 4)
  list(id = "close", file = "close.csv", value = "value", where = NULL))
cat("fixture,key,value\n")
out <- function(id, key, v) cat(sprintf("%s,%s,%.17g\n", id, key, v))
for (f in fixtures) {
  d <- read.csv(f$file, stringsAsFactors = FALSE)
  if (!is.null(f$where)) d <- d[d[[f$where[1]]] == f$where[2], ]
  y <- d[[f$value]]
  g <- factor(d$group, levels = unique(d$group))
  lv <- levels(g); k <- length(lv); xs <- split(y, g)
  m <- 0.07 * mean(y)
  for (i in 1:(k - 1)) for (j in (i + 1):k) {
    a <- xs[[i]]; b <- xs[[j]]; key <- paste0(lv[i], ".", lv[j])
    nu <- length(a) + length(b) - 2
    sp <- sqrt(((length(a) - 1) * var(a) + (length(b) - 1) * var(b)) / nu)
    wt <- t.test(a, b)
    tw <- unname(wt$statistic); dfw <- unname(wt$parameter); sew <- unname(wt$stderr)
    if (sp > 0) {
      lo <- uniroot(function(x) pt(tw, dfw, ncp = x) - 0.975, c(tw - 40, tw + 40), tol = 1e-14)$root
      hi <- uniroot(function(x) pt(tw, dfw, ncp = x) - 0.025, c(tw - 40, tw + 40), tol = 1e-14)$root
      out(id = f$id, paste0("dw.", key, ".lo"), lo * sew / sp)
      out(id = f$id, paste0("dw.", key, ".hi"), hi * sew / sp)
    }
    pl <- t.test(a, b, mu = -m, alternative = "greater")$p.value
    ph <- t.test(a, b, mu = m, alternative = "less")$p.value
    ci <- t.test(a, b, conf.level = 0.90)$conf.int
    out(f$id, paste0("tost.", key, ".p_low"), pl)
    out(f$id, paste0("tost.", key, ".p_high"), ph)
    out(f$id, paste0("tost.", key, ".p"), max(pl, ph))
    out(f$id, paste0("tost.", key, ".lo90"), ci[1])
    out(f$id, paste0("tost.", key, ".hi90"), ci[2])
    out(f$id, paste0("tost.", key, ".margin"), m)
    verdict <- if (max(pl, ph) < 0.05) "equivalent" else if (wt$p.value < 0.05) "different" else "inconclusive"
    cat(sprintf("%s,tost.%s.verdict,%s\n", f$id, key, verdict))
  }
}
