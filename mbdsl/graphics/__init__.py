"""Drawing a run: time-history figures and animations (``plotting.py``,
matplotlib), the interactive browser page (``viewer.py``, plotly), both from
one description of the mechanism's drawing (``scene.py``)."""
