"""Identification: estimators, experiments, measured series and the comparison with the nets."""
