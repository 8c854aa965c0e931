"""Experiments: single runs and Monte Carlo."""
