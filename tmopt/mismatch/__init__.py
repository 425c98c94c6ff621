"""Simulation vs recording: locate, explain and model a mismatch."""
