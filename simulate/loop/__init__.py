"""The time loop: generated from the compiled components and cached on disk, its steady start, the checks before a run,
and where the characteristics can be trusted."""
