"""Reference implementations (oracles) that tests and benchmarks compare production code with.

Not part of the package: import as ``oracles`` (``tests/`` is on ``sys.path`` under pytest;
benchmarks add it). ``scan``: the all-in-one lidar scan; ``sensors``: the Python sensors.
"""
