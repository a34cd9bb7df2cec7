"""Model discrepancy (issue 8): confront predictions with measured data, name the cause, extend the
model, measure the gain.

* :mod:`~gearfem.diagnose.data`: the measured-data CSV format and its reader;
* :mod:`~gearfem.diagnose.candidates`: the library of candidate extensions;
* :mod:`~gearfem.diagnose.forward`: the full forward model and its surrogate;
* :mod:`~gearfem.diagnose.vv20`: ASME V&V 20 comparison;
* :mod:`~gearfem.diagnose.select`: fitting, ranking, identifiability, held-out error;
* :mod:`~gearfem.diagnose.report`: ``gearfem diagnose`` (diagnosis.json, report.md, plots).
"""
