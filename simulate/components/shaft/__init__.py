"""The shaft: the rotor's swing equation, alone or with the sub-transient generator."""
