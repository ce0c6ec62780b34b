"""Analyses of the study's results.

* :mod:`.tables` -- summary and comparison tables in the paper's layout, and provenance;
* :mod:`.beyond` -- the tables of Exps 7-11 (noise, observations, a physics baseline, the
  multirotor, the future work);
* :mod:`.filters` -- RotorPy's wind filters, calibrated and compared (Exp 11);
* :mod:`.closed_loop` -- Exp 12's accuracy against time, calibration and manoeuvres;
* :mod:`.exp13` -- Exp 13 as one run (the real flights, then their twin), registered with the
  study's registry;
* :mod:`.inference` -- the paper's unstated setup, recovered from its Table 4 and tested;
* :mod:`.claims` -- the paper's claims, judged with uncertainty;
* :mod:`.memo` -- a table an analysis computes once, in the one verified cache;
* :mod:`.page_analyses` -- the analyses the pages read, each registered where it is defined
  as the fill's task, and the settings they fly.

Imports the layers below it, never :mod:`uavwind.report`.
"""

from .tables import comparison_table, provenance, summary_table

__all__ = ["comparison_table", "provenance", "summary_table"]
