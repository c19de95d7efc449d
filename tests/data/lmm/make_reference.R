# Reference values for palplab lmm (tests/analysis/test_lmm.cpp), from lme4 + lmerTest.
# Run once from the repository root:  Rscript tests/data/lmm/make_reference.R
# Writes the fixtures sleepstudy.csv and study.csv (if absent) and reference.csv with one
# value per line (model, method, quantity, term, value) printed with 17 significant digits.
# The optimiser is run to a much tighter tolerance than lme4's default so that the reference
# optimum is accurate to far better than the 1e-6 the tests ask for.
suppressPackageStartupMessages({ library(lme4); library(lmerTest) })
dir <- "tests/data/lmm"

if (!file.exists(file.path(dir, "sleepstudy.csv")))
  write.csv(lme4::sleepstudy[, c("Reaction", "Days", "Subject")],
            file.path(dir, "sleepstudy.csv"), row.names = FALSE, quote = FALSE)

# A palplab-like study: 3 groups x 8 participants x 5 sessions, one missing session (NA),
# unbalanced groups, a learning trend with group-specific slopes.
if (!file.exists(file.path(dir, "study.csv"))) {
  set.seed(20261124)
  rows <- list()
  pid <- 0
  for (g in c("A", "B", "C")) {
    np <- c(A = 8, B = 7, C = 8)[[g]]
    for (k in seq_len(np)) {
      pid <- pid + 1
      u0 <- rnorm(1, 0, 0.6); u1 <- rnorm(1, 0, 0.15)
      for (s in 1:5) {
        mu <- 4 + c(A = 0, B = 0.5, C = 1.1)[[g]] + (-0.3 + c(A = 0, B = -0.1, C = -0.25)[[g]]) * s
        v <- round(mu + u0 + u1 * s + rnorm(1, 0, 0.4), 4)
        rows[[length(rows) + 1]] <- data.frame(participant = sprintf("P%02d", pid), group = g,
                                               session = s, value = v)
      }
    }
  }
  d <- do.call(rbind, rows)
  d$value[7] <- NA
  write.csv(d, file.path(dir, "study.csv"), row.names = FALSE, quote = FALSE, na = "NA")
}

# The same study with the session as a factor (S1..S5): a factor-by-factor interaction.
if (!file.exists(file.path(dir, "study_blocks.csv"))) {
  d <- read.csv(file.path(dir, "study.csv"))
  d$block <- paste0("S", d$session)
  d$session <- NULL
  write.csv(d, file.path(dir, "study_blocks.csv"), row.names = FALSE, quote = FALSE, na = "NA")
}

sleep <- read.csv(file.path(dir, "sleepstudy.csv"))
study <- read.csv(file.path(dir, "study.csv"))
blocks <- read.csv(file.path(dir, "study_blocks.csv"))
ctrl <- lmerControl(optimizer = "bobyqa", calc.derivs = FALSE,
                    optCtrl = list(rhobeg = 0.2, rhoend = 1e-12, maxfun = 1e5))

models <- list(
  list(name = "sleep_slope", data = sleep, formula = Reaction ~ Days + (Days | Subject)),
  list(name = "sleep_int", data = sleep, formula = Reaction ~ Days + (1 | Subject)),
  list(name = "study_int", data = study, formula = value ~ group * session + (1 | participant)),
  list(name = "study_slope", data = study,
       formula = value ~ group * session + (1 + session | participant)),
  list(name = "study_blocks", data = blocks, formula = value ~ group * block + (1 | participant)))

out <- data.frame(model = character(), method = character(), quantity = character(),
                  term = character(), value = character())
add <- function(m, meth, q, term, v)
  out[nrow(out) + 1, ] <<- list(m, meth, q, term, sprintf("%.17g", v))

for (mod in models) for (reml in c(TRUE, FALSE)) {
  meth <- if (reml) "REML" else "ML"
  fit <- lmerTest::lmer(mod$formula, data = mod$data, REML = reml, control = ctrl)
  cf <- summary(fit)$coefficients
  for (i in seq_len(nrow(cf))) {
    t <- rownames(cf)[i]
    add(mod$name, meth, "estimate", t, cf[i, "Estimate"])
    add(mod$name, meth, "se", t, cf[i, "Std. Error"])
    add(mod$name, meth, "t", t, cf[i, "t value"])
    add(mod$name, meth, "df", t, cf[i, "df"])
    add(mod$name, meth, "p", t, cf[i, "Pr(>|t|)"])
  }
  vc <- as.data.frame(VarCorr(fit))
  add(mod$name, meth, "sd_intercept", "", vc$sdcor[1])
  if (nrow(vc) == 4) {
    add(mod$name, meth, "sd_slope", "", vc$sdcor[2])
    add(mod$name, meth, "correlation", "", vc$sdcor[3])
  }
  add(mod$name, meth, "sigma", "", sigma(fit))
  ll <- logLik(fit)
  add(mod$name, meth, "loglik", "", as.numeric(ll))
  add(mod$name, meth, "deviance", "", if (reml) REMLcrit(fit) else deviance(fit))
  add(mod$name, meth, "aic", "", AIC(fit))
  add(mod$name, meth, "bic", "", BIC(fit))
  th <- getME(fit, "theta")
  for (i in seq_along(th)) add(mod$name, meth, "theta", as.character(i - 1), th[i])
  an <- anova(fit, type = 3, ddf = "Satterthwaite")
  for (i in seq_len(nrow(an))) {
    t <- rownames(an)[i]
    add(mod$name, meth, "F", t, an[i, "F value"])
    add(mod$name, meth, "NumDF", t, an[i, "NumDF"])
    add(mod$name, meth, "DenDF", t, an[i, "DenDF"])
    add(mod$name, meth, "F_p", t, an[i, "Pr(>F)"])
    add(mod$name, meth, "SumSq", t, an[i, "Sum Sq"])
  }
}
write.csv(out, file.path(dir, "reference.csv"), row.names = FALSE, quote = FALSE)
cat("wrote", nrow(out), "reference values\n")
