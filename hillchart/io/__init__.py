"""Reading what a user digitized and writing result files."""
