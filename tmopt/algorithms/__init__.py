"""Optimisers, one file each, with setup/ask/tell steps."""
