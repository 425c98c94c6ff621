"""Sweep reporting behind ``python -m tmopt.collect``: runs, statistics, tables, figures."""
