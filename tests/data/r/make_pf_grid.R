# Upper tails of the F distribution (R's pf, TOMS 708 incomplete beta: ~1e-14 relative) on a
# grid that includes far tails with large denominator df, where GSL's gsl_cdf_fdist_Q loses
# digits or underflows. Two-sided t p-values are the d1 = 1 rows (t = sqrt(f)).
#   Rscript make_pf_grid.R > pf_grid.csv
cat("f,d1,d2,p\n")
for (d1 in c(1, 2, 3, 8)) for (d2 in c(0.7, 1, 2.5, 7, 29, 180, 1000, 1e5, 1e6))
  for (f in c(0.01, 0.5, 1, 3, 10, 32, 100, 800)) {
    p <- pf(f, d1, d2, lower.tail = FALSE)
    if (p > 1e-300) cat(sprintf("%.17g,%.17g,%.17g,%.17g\n", f, d1, d2, p))
  }
