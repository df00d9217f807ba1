"""Normative models, pure: transforms to normality, the regression on covariates, Z-scores,
task scores, and test-retest reliability (ICC, SEM, MDC95). The file, its verification
and the fitting from trial files are app.norms; docs/norms.md documents both."""
