"""Instrument models: what the bench's IR camera, a thermocouple and the torque meters read.

A model field is not a measurement; an instrument maps the run's fields to what it reports, so
that a prediction can be compared with a measurement of the same quantity (issue 13):

* :mod:`~gearfem.instruments.options`: the ``[instruments]`` table (camera, probes, torque meters);
* :mod:`~gearfem.instruments.radiometry`: band radiance (Planck over the detector's band) and the
  camera's emissivity/reflected-temperature inversion;
* :mod:`~gearfem.instruments.snapshot`: the rank-independent fields a finished run keeps
  (``instruments/snapshot.npz``), gathered by :mod:`~gearfem.instruments.gather`;
* :mod:`~gearfem.instruments.scene` and :mod:`~gearfem.instruments.raster`: the gears' whole
  surfaces and z-buffer visibility;
* :mod:`~gearfem.instruments.camera`: pixel footprints, blur, rotation and detector response,
  ``camera_max`` and the thermogram (:mod:`~gearfem.instruments.thermogram`);
* :mod:`~gearfem.instruments.probes`: thermocouple, side-face spot, reported field values;
* :mod:`~gearfem.instruments.torque`: torque loss and efficiency from the cycle's torques;
* :mod:`~gearfem.instruments.evaluate`: all readings of a snapshot (:class:`InstrumentReadings`).
"""
