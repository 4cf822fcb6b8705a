"""What a run returns: the result record, the head envelope along the penstock."""
