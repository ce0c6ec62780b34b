"""Analyses of the study's results.

* :mod:`.tables` -- summary and comparison tables in the paper's layout, and provenance;
* :mod:`.beyond` -- the tables of Exps 7-9 (noise, observations, a physics baseline);
* :mod:`.inference` -- the paper's unstated setup, recovered from its Table 4 and tested;
* :mod:`.claims` -- the paper's claims, judged with uncertainty.

Imports the layers below it, never :mod:`uavwind.report`.
"""

from .tables import comparison_table, provenance, summary_table

__all__ = ["comparison_table", "provenance", "summary_table"]
