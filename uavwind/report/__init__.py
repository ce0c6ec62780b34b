"""Presentation: display names, figures, the static explorer and the performance page.

The top library layer: it may import every layer below, and nothing imports it but the
command line and the notebooks.
"""
