# Generates the CSV fixtures of tests/data/r (run once; the CSVs are committed).
#   Rscript make_fixtures.R
# Values are rounded to a few decimals so the CSV text is the exact data R and palplab read.
set.seed(20261121)
w <- function(df, name) write.csv(df, name, row.names = FALSE, quote = TRUE)
# 1. three groups, unequal n and unequal variances, plus a 'phase' column for --where
g1 <- data.frame(group = rep(c("A", "B", "C"), c(10, 14, 8)),
                 force = round(c(rnorm(10, 2.5, 0.3), rnorm(14, 2.1, 0.8), rnorm(8, 3.2, 1.6)), 4))
g1$phase <- rep(c("post", "pre"), length.out = nrow(g1))
w(g1, "unequal.csv")
# 2. integer scores with many ties, four groups
w(data.frame(group = rep(c("g1", "g2", "g3", "g4"), c(9, 12, 7, 10)),
             score = c(sample(1:6, 9, TRUE), sample(2:7, 12, TRUE), sample(1:4, 7, TRUE),
                       sample(3:8, 10, TRUE))), "ties.csv")
# 3. n = 2 in every group
w(data.frame(group = rep(c("x", "y", "z"), each = 2), value = c(1.5, 2.25, 3.0, 4.75, 2.0, 2.5)),
  "n2.csv")
# 4. one constant group (zero variance) beside two variable ones
w(data.frame(group = rep(c("const", "u", "v"), c(5, 6, 7)),
             value = c(rep(3.3, 5), round(rnorm(6, 4, 1), 3), round(rnorm(7, 5, 2), 3))),
  "constant.csv")
# 5. small samples without ties (exact Mann-Whitney), two groups, large offset
w(data.frame(group = rep(c("ctl", "trt"), c(7, 9)),
             value = 1e6 + round(c(rnorm(7, 0, 1), rnorm(9, 1.2, 1)), 5)), "offset_two.csv")
# 6. larger groups (normal approximation of Mann-Whitney without ties, Shapiro-Wilk n >= 12)
w(data.frame(group = rep(c("p", "q", "r"), c(60, 55, 70)),
             value = round(c(rnorm(60, 10, 2), rexp(55, 0.1), rnorm(70, 11, 3)), 6)), "large.csv")
