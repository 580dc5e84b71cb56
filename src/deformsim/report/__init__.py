"""The experiment report: one self-contained HTML page built from ``metrics.json``."""
