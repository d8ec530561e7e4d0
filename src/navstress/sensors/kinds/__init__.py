"""The sensor kinds: one module each, defining ``KIND`` (a :class:`navstress.sensors.base.SensorKind`).
The registry (:mod:`navstress.sensors.registry`) finds every module of this package."""
