"""Surrogate models: fit(X, Y), predict(X) -> (mean, std)."""
