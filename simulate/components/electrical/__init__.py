"""The electrical side: the synchronous generator and its grid."""
