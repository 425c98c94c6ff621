"""Design the next excitation from a mismatch diagnosis: what the recording could not
identify (not excited, aliased) becomes the objectives of a tmopt problem whose decision
variables are the motions of both test masses on their sensitive and non-sensitive axes
(``python -m tmopt.design``; docs/design.md)."""
