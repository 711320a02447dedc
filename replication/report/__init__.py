"""Reports: markdown, figures and CSV data made from experiment results (never computing science)."""
