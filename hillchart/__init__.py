"""hillchart: from a digitized Francis hill chart to fast, differentiable Q11/M11 characteristics.

Data flows one way::

    chart folder -> hillchart.samples -> hillchart.extend -> hillchart.nets -> hillchart.linearize

``hillchart`` never imports ``simulate``.
"""

__version__ = "0.1.0"
