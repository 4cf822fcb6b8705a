"""One module per ``hillsim`` sub-command."""
