"""Control: speed governor and servos, voltage control."""
