"""Plots and reports (matplotlib, HTML): adapters over core results."""
