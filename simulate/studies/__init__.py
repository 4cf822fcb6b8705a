"""Design studies: batches, sweeps, closure-law optimization, load cases, ensemble bands."""
