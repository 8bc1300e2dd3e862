"""Reproductions of the paper's tables and figures (`fluxcal experiment NAME -o DIR`)."""

EXPERIMENTS = ("table1", "table2", "fig6", "fig7", "fig8", "smearing", "lag")
