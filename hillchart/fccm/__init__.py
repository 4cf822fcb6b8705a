"""Full characteristic curve map of a double-regulated turbine (test tables, multi-output net, maps)."""
