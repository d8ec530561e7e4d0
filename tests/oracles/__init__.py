"""Reference implementations (oracles) that tests and benchmarks compare production code with.

Not part of the package: import as ``tests.oracles`` (the repository root is on ``sys.path``
under pytest: pyproject's ``pythonpath``). ``scan``: the all-in-one lidar scan; ``sensors``: the Python sensors.
"""
