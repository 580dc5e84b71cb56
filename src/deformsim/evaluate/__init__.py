"""Evaluation: classification metrics, the paper's Table II experiments and PCA plots of the domains."""
