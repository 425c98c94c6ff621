"""Problems an optimiser sees: vectorised pymoo problems with constraint groups."""
