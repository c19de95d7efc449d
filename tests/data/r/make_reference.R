# Reference values for tests/analysis/test_vs_r.cpp, computed with base R only.
#   Rscript make_reference.R > reference.csv      (R 4.2.2 produced the committed file)
# One line per value: fixture,key,value (17 significant digits). Pairs a.b follow the order of
# first appearance of the groups, and differences are mean(a) - mean(b) (palplab's convention;
# TukeyHSD's "b-a" rows are negated to match).
options(warn = -1)
fixtures <- list(
  list(id = "unequal", file = "unequal.csv", value = "force", where = NULL),
  list(id = "unequal_post", file = "unequal.csv", value = "force", where = c("phase", "post")),
  list(id = "ties", file = "ties.csv", value = "score", where = NULL),
  list(id = "n2", file = "n2.csv", value = "value", where = NULL),
  list(id = "constant", file = "constant.csv", value = "value", where = NULL),
  list(id = "offset_two", file = "offset_two.csv", value = "value", where = NULL, centre = 1e6),
  list(id = "large", file = "large.csv", value = "value", where = NULL))
cat("fixture,key,value\n")
out <- function(id, key, v) cat(sprintf("%s,%s,%.17g\n", id, key, v))
for (f in fixtures) {
  d <- read.csv(f$file, stringsAsFactors = FALSE)
  if (!is.null(f$where)) d <- d[d[[f$where[1]]] == f$where[2], ]
  y <- d[[f$value]]
  # Values 1e6 + 5 decimals lose ~1e-10 of their deviations when read as double; R gets the
  # exact deviations (rounding the difference to the 5 decimals of the text) so that the
  # reference is not limited by its input. Every statistic but the means is shift-invariant.
  centre <- if (is.null(f$centre)) 0 else f$centre
  if (centre != 0) y <- round(y - centre, 5)
  g <- factor(d$group, levels = unique(d$group))
  lv <- levels(g); k <- length(lv)
  xs <- split(y, g)
  n <- sapply(xs, length); m <- sapply(xs, mean); v <- sapply(xs, var)
  id <- f$id
  for (i in seq_len(k)) {
    out(id, paste0("n.", lv[i]), n[i]); out(id, paste0("mean.", lv[i]), centre + m[i])
    out(id, paste0("sd.", lv[i]), sqrt(v[i]))
    qs <- quantile(xs[[i]], c(0.25, 0.5, 0.75), type = 7)
    out(id, paste0("q1.", lv[i]), centre + qs[1]); out(id, paste0("median.", lv[i]), centre + qs[2])
    out(id, paste0("q3.", lv[i]), centre + qs[3])
    if (v[i] > 0) {
      ci <- t.test(xs[[i]])$conf.int
      out(id, paste0("ci.", lv[i], ".lo"), centre + ci[1]); out(id, paste0("ci.", lv[i], ".hi"), centre + ci[2])
    }
    if (n[i] >= 3 && v[i] > 0) {
      sw <- shapiro.test(xs[[i]])
      out(id, paste0("sw.", lv[i], ".W"), sw$statistic); out(id, paste0("sw.", lv[i], ".p"), sw$p.value)
    }
  }
  fit <- anova(lm(y ~ g))
  out(id, "anova.F", fit[1, "F value"]); out(id, "anova.p", fit[1, "Pr(>F)"])
  out(id, "anova.df1", fit[1, "Df"]); out(id, "anova.df2", fit[2, "Df"])
  ssb <- fit[1, "Sum Sq"]; ssw <- fit[2, "Sum Sq"]; msw <- fit[2, "Mean Sq"]
  out(id, "anova.eta2", ssb / (ssb + ssw))
  out(id, "anova.omega2", (ssb - (k - 1) * msw) / (ssb + ssw + msw))
  if (all(v > 0)) {
    ow <- oneway.test(y ~ g, var.equal = FALSE)
    out(id, "welch.F", ow$statistic); out(id, "welch.df2", ow$parameter[2]); out(id, "welch.p", ow$p.value)
  }
  # Levene (mean-centred) and Brown-Forsythe (median-centred): ANOVA of absolute deviations.
  lev <- anova(lm(abs(y - ave(y, g, FUN = mean)) ~ g))
  bf <- anova(lm(abs(y - ave(y, g, FUN = median)) ~ g))
  out(id, "levene.F", lev[1, "F value"]); out(id, "levene.p", lev[1, "Pr(>F)"])
  out(id, "bf.F", bf[1, "F value"]); out(id, "bf.p", bf[1, "Pr(>F)"])
  kw <- kruskal.test(y ~ g)
  out(id, "kw.H", kw$statistic); out(id, "kw.p", kw$p.value)
  # Pairwise tests.
  pw <- c(); keys <- c()
  tk <- TukeyHSD(aov(y ~ g), conf.level = 0.95)$g
  for (i in 1:(k - 1)) for (j in (i + 1):k) {
    a <- xs[[i]]; b <- xs[[j]]; key <- paste0(lv[i], ".", lv[j])
    st <- t.test(a, b, var.equal = TRUE)
    out(id, paste0("student.", key, ".t"), st$statistic); out(id, paste0("student.", key, ".p"), st$p.value)
    if (var(a) > 0 || var(b) > 0) {
      wt <- t.test(a, b, var.equal = FALSE)
      out(id, paste0("welch.", key, ".t"), wt$statistic); out(id, paste0("welch.", key, ".df"), wt$parameter)
      out(id, paste0("welch.", key, ".p"), wt$p.value)
      out(id, paste0("welch.", key, ".lo"), wt$conf.int[1]); out(id, paste0("welch.", key, ".hi"), wt$conf.int[2])
      fdf <- max(1, floor(wt$parameter))
      out(id, paste0("floor.", key, ".df"), fdf)
      out(id, paste0("floor.", key, ".p"), 2 * pt(-abs(wt$statistic), fdf))
      pw <- c(pw, wt$p.value); keys <- c(keys, key)
      # Games-Howell
      se <- sqrt((var(a) / length(a) + var(b) / length(b)) / 2)
      q <- abs(mean(a) - mean(b)) / se
      out(id, paste0("gh.", key, ".q"), q); out(id, paste0("gh.", key, ".df"), wt$parameter)
      out(id, paste0("gh.", key, ".p"), ptukey(q, k, wt$parameter, lower.tail = FALSE))
    }
    row <- tk[paste0(lv[j], "-", lv[i]), ]
    out(id, paste0("tukey.", key, ".diff"), -row["diff"]); out(id, paste0("tukey.", key, ".p"), row["p adj"])
    out(id, paste0("tukey.", key, ".lwr"), -row["upr"]); out(id, paste0("tukey.", key, ".upr"), -row["lwr"])
    # Cohen's d, Hedges' g (exact J) and the noncentral-t CI of d.
    nu <- length(a) + length(b) - 2
    sp <- sqrt(((length(a) - 1) * var(a) + (length(b) - 1) * var(b)) / nu)
    if (sp > 0) {
      dd <- (mean(a) - mean(b)) / sp
      J <- exp(lgamma(nu / 2) - lgamma((nu - 1) / 2)) / sqrt(nu / 2)
      out(id, paste0("d.", key), dd); out(id, paste0("g.", key), J * dd)
      sc <- sqrt(1 / length(a) + 1 / length(b)); tt <- dd / sc
      lo <- uniroot(function(x) pt(tt, nu, ncp = x) - 0.975, c(tt - 40, tt + 40), tol = 1e-14)$root
      hi <- uniroot(function(x) pt(tt, nu, ncp = x) - 0.025, c(tt - 40, tt + 40), tol = 1e-14)$root
      out(id, paste0("d.", key, ".lo"), lo * sc); out(id, paste0("d.", key, ".hi"), hi * sc)
    }
    mw <- wilcox.test(a, b)
    out(id, paste0("mw.", key, ".W"), mw$statistic); out(id, paste0("mw.", key, ".p"), mw$p.value)
    ties <- length(unique(c(a, b))) < length(c(a, b))
    out(id, paste0("mw.", key, ".exact"), as.numeric(length(a) < 50 && length(b) < 50 && !ties))
  }
  if (length(pw)) {
    ph <- p.adjust(pw, "holm"); pb <- p.adjust(pw, "bonferroni")
    for (i in seq_along(keys)) { out(id, paste0("holm.", keys[i]), ph[i]); out(id, paste0("bonf.", keys[i]), pb[i]) }
  }
}
