"""hillsim command line: the ``hillsim`` console script and the end-to-end demo.

This package glues :mod:`hillchart` and :mod:`simulate` together; neither of them imports it.
"""

__version__ = "0.1.0"
