"""The Monte Carlo evaluation: trials over variants, their store, the report (Table 1, Figs. 2-3)."""
