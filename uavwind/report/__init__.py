"""Presentation: display names, figures, the static explorer and the performance page.

* :mod:`.display` -- the project's vocabulary as display names;
* :mod:`.plotting` -- the paper's figures; :mod:`.beyond_figures` -- the figures beyond it;
* :mod:`.sweeps` -- the pages of the paper's sweeps (Exps 2-4), one call each;
* :mod:`.explore` -- the Explore page, live and static;
* :mod:`.performance` -- the performance page's tables from a benchmark report.

The top library layer: it may import every layer below, and nothing imports it but the
command line and the notebooks.
"""
